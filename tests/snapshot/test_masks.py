"""Masks under the spacing rule: the check, uniform and random masks, the physical footprints."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.errors import ProcedureError
from sassi_bench.snapshot import check_mask, mask_conflicts, random_mask, uniform_mask


def camera_rectangles(bundle, mask, k=3.0, margin=3.0):
    """Each open pixel's lit camera rectangle (x0, x1, y0, y1) from bundle.slm_to_camera."""
    rows, cols = np.nonzero(mask)
    edges = bundle.bin_edges[[0, -1]]
    x, _ = bundle.slm_to_camera(cols[:, None], rows[:, None], edges)
    sig = bundle.blur_width(edges)
    lam = np.linspace(bundle.bin_edges[0], bundle.bin_edges[-1], 301)
    _, y = bundle.slm_to_camera(cols[:, None], rows[:, None], bundle.wavelengths)
    reach_y = k * bundle.blur_width(lam).max()
    x0 = np.minimum(x[:, 0] - k * sig[0], x[:, 1] - k * sig[1]) - margin
    x1 = np.maximum(x[:, 0] + k * sig[0], x[:, 1] + k * sig[1]) + margin
    return x0, x1, y.min(1) - reach_y, y.max(1) + reach_y


def overlapping_pairs(bundle, mask):
    x0, x1, y0, y1 = camera_rectangles(bundle, mask)
    hit = (
        (x0[:, None] <= x1[None, :])
        & (x0[None, :] <= x1[:, None])
        & (y0[:, None] <= y1[None, :])
        & (y0[None, :] <= y1[:, None])
    )
    np.fill_diagonal(hit, False)
    return int(hit.sum()) // 2


@pytest.mark.parametrize("kind", ["uniform", "random"])
def test_masks_under_the_rule_have_no_overlapping_streaks(
    synthetic_bundle, synthetic_spacing, helpers, kind
):
    mask = (
        uniform_mask(synthetic_spacing, (3, 7))
        if kind == "uniform"
        else random_mask(synthetic_spacing, seed=3)
    )
    assert mask.sum() > 100
    assert overlapping_pairs(synthetic_bundle, mask) == 0
    assert helpers.pairs_in_conflict(mask, synthetic_spacing) == []
    check_mask(mask, synthetic_spacing)


def test_one_pixel_closer_overlaps_and_is_refused(synthetic_bundle, synthetic_spacing):
    v, u = 200, 300
    mask = np.zeros(synthetic_spacing.slm_shape, bool)
    mask[v, u] = True
    mask[v, u + synthetic_spacing.right[v, u] + 1] = True
    assert overlapping_pairs(synthetic_bundle, mask) == 0
    check_mask(mask, synthetic_spacing)
    closer = np.zeros_like(mask)
    closer[v, u] = closer[v, u + synthetic_spacing.right[v, u]] = True
    assert overlapping_pairs(synthetic_bundle, closer) == 1
    with pytest.raises(ProcedureError, match=r"mask check: 2 of 2 open pixels .* Fix: space"):
        check_mask(closer, synthetic_spacing)


def test_conflicts_agree_with_brute_force(helpers):
    spacing = helpers.odd_spacing()
    rng = np.random.default_rng(5)
    for _ in range(20):
        mask = rng.random(spacing.slm_shape) < 0.01
        brute = {p for pair in helpers.pairs_in_conflict(mask, spacing) for p in pair[:1]}
        found = {tuple(p) for p in mask_conflicts(mask, spacing).tolist()}
        assert found == brute


def test_random_mask_is_maximal_and_keeps_the_rule(helpers):
    spacing = helpers.odd_spacing(seed=2)
    mask = random_mask(spacing, seed=4)
    assert helpers.pairs_in_conflict(mask, spacing) == []
    # Maximal: no closed pixel could be opened.
    for r, c in zip(*np.nonzero(~mask), strict=True):
        trial = mask.copy()
        trial[r, c] = True
        assert helpers.pairs_in_conflict(trial, spacing)
    assert random_mask(spacing, count=5, seed=4).sum() == 5


def test_bad_masks_are_refused(synthetic_spacing):
    with pytest.raises(ProcedureError, match="shape"):
        check_mask(np.zeros((3, 3), bool), synthetic_spacing)
    with pytest.raises(ProcedureError, match="opens no pixel"):
        check_mask(np.zeros(synthetic_spacing.slm_shape, bool), synthetic_spacing)
    with pytest.raises(ProcedureError, match="boolean"):
        check_mask(np.full(synthetic_spacing.slm_shape, 0.5), synthetic_spacing)
