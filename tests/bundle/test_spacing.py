"""Mask spacing against streak footprints computed independently from the bundle's streaks."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.bundle import BundleError, MaskSpacing, load, mask_spacing


@pytest.fixture(scope="module")
def bundle(tmp_path_factory, synthetic):
    return load(synthetic.publish_synthetic(tmp_path_factory.mktemp("spacing")))


@pytest.fixture(scope="module")
def spacing(bundle):
    return bundle.mask_spacing()


def footprint(bundle, u, v, k=3.0, margin=3.0):
    """Camera rectangle (x0, x1, y0, y1) that pixel (u, v)'s light reaches: from the
    bundle's own streak and blur, not from the spacing code."""
    s = bundle.streak(u, v)
    sig = bundle.blur_width(bundle.bin_edges[[0, -1]])
    sig_max = bundle.blur_width(np.linspace(bundle.bin_edges[0], bundle.bin_edges[-1], 301)).max()
    ends = np.array(
        [bundle.slm_to_camera(u, v, lam)[0] for lam in bundle.bin_edges[[0, -1]]]
    ).ravel()
    x0 = min(ends[0] - k * sig[0], ends[1] - k * sig[1]) - margin
    x1 = max(ends[0] + k * sig[0], ends[1] + k * sig[1]) + margin
    return x0, x1, s.y.min() - k * sig_max, s.y.max() + k * sig_max


def overlap(a, b):
    return a[0] <= b[1] and b[0] <= a[1]


FIELD = [(320, 200), (5, 3), (600, 390), (100, 250), (630, 20)]


@pytest.mark.parametrize(("u", "v"), FIELD)
def test_window_is_exactly_where_footprints_overlap_in_the_band(bundle, spacing, u, v):
    # The window reaches the farthest column whose footprint overlaps this pixel's in some
    # row less than `pitch` away, and no farther.
    h, w = bundle.slm_shape
    me = footprint(bundle, u, v)
    band = range(max(0, v - spacing.pitch + 1), min(h, v + spacing.pitch))
    right, left = int(spacing.right[v, u]), int(spacing.left[v, u])
    for du, reach in ((1, right), (-1, left)):
        edge = u + du * reach
        beyond = edge + du
        if 0 <= beyond < w:
            assert not any(overlap(me[:2], footprint(bundle, beyond, r)[:2]) for r in band)
        if reach > 0:
            assert any(overlap(me[:2], footprint(bundle, edge, r)[:2]) for r in band)


def test_spacing_follows_the_field_and_the_blur(bundle, spacing):
    gap = spacing.left + spacing.right
    assert gap[200, 50:590].max() > gap[200, 50:590].min()  # not a constant
    wider = bundle.mask_spacing(blur_sigmas=5.0)
    assert (wider.right >= spacing.right).all() and wider.right[200, 320] > spacing.right[200, 320]
    assert wider.pitch > spacing.pitch
    denser = bundle.mask_spacing(row_sigmas=1.0)
    assert denser.pitch < spacing.pitch
    assert denser.row_sigmas == 1.0 and spacing.row_sigmas == 3.0


def test_pitch_keeps_rows_apart_and_is_tight(bundle, spacing):
    p = spacing.pitch
    tightest = 0
    for u, v in FIELD:
        v = min(v, bundle.slm_shape[0] - 1 - p)
        me = footprint(bundle, u, v)
        for du in (-int(spacing.left[v, u]), 0, int(spacing.right[v, u])):
            other = footprint(bundle, u + du, v + p)
            assert not overlap(me[2:], other[2:])
        gaps = [d for d in range(1, p + 1) if not overlap(me[2:], footprint(bundle, u, v + d)[2:])]
        tightest = max(tightest, min(gaps))
    # Conservative (field maximum, drift across the window), but not by much.
    assert tightest <= p <= tightest + 2


def test_window_and_uniform_step():
    s = MaskSpacing(np.full((10, 30), 2), np.full((10, 30), 4), 3, 3.0, 3.0)
    assert s.window(0, 0) == (0, 2, 0, 4)
    assert s.window(29, 9) == (7, 9, 27, 29)
    assert s.uniform_step == 5
    assert not s.left.flags.writeable


def test_spacing_needs_only_the_models(bundle, spacing):
    """The rule is a function of the dispersion, bins and blur: the bundle's method is the
    same computation on its models."""
    from_models = mask_spacing(bundle.models)
    np.testing.assert_array_equal(from_models.left, spacing.left)
    np.testing.assert_array_equal(from_models.right, spacing.right)
    assert from_models.pitch == spacing.pitch


def test_bad_parameters_are_refused(bundle):
    with pytest.raises(BundleError, match="blur_sigmas"):
        bundle.mask_spacing(blur_sigmas=-1.0)


@pytest.mark.parametrize(("u", "v"), FIELD)
def test_row_pitch_keeps_columns_apart_within_the_pitch(bundle, spacing, u, v):
    """A set pitch (the paper's 5 rows): within it the columns are those where footprints
    overlap (the same exact reach as the default rule, over fewer rows), beyond it any."""
    dense = bundle.mask_spacing(row_pitch=5)
    assert dense.pitch == 5 < spacing.pitch
    h, w = bundle.slm_shape
    mine = footprint(bundle, u, v)
    for dv in range(-4, 5):
        vv = min(max(v + dv, 0), h - 1)
        for du in (dense.right[v, u] + 1, -dense.left[v, u] - 1):
            if 0 <= u + du < w:
                assert not overlap(mine[:2], footprint(bundle, u + du, vv)[:2])
    assert np.all(dense.right <= spacing.right) and np.all(dense.left <= spacing.left)


def test_bad_row_pitch_is_refused(bundle):
    with pytest.raises(BundleError, match="row_pitch"):
        bundle.mask_spacing(row_pitch=0)
