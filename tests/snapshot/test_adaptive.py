"""Adaptive masks: the rule is never broken, every superpixel with room is sampled, regions."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.errors import ProcedureError
from sassi_bench.snapshot import (
    adaptive_mask,
    guide_on_slm,
    place_samples,
    segment_around_samples,
    superpixels,
)


def blocky_labels(shape, block, seed):
    """Superpixel-like labels: jittered blocks, relabelled 0..K-1."""
    rng = np.random.default_rng(seed)
    rows = (np.arange(shape[0])[:, None] + rng.integers(0, block, (1, shape[1]))) // block
    cols = (np.arange(shape[1])[None, :] + rng.integers(0, block, (shape[0], 1))) // block
    _, labels = np.unique(rows * 1000 + cols, return_inverse=True)
    return labels.reshape(shape).astype(np.int32)


@pytest.mark.parametrize("seed", range(4))
def test_adaptive_samples_keep_the_rule_and_take_every_superpixel_with_room(helpers, seed):
    spacing = helpers.odd_spacing(seed=seed)
    labels = blocky_labels(spacing.slm_shape, 6, seed)
    mask, samples = place_samples(labels, spacing, fill=False)
    assert helpers.pairs_in_conflict(mask, spacing) == []
    assert mask.sum() == len(samples) and mask[samples[:, 0], samples[:, 1]].all()
    # One sample per superpixel at most, inside it.
    owners = labels[samples[:, 0], samples[:, 1]]
    assert np.unique(owners).size == owners.size
    # A superpixel without a sample has no pixel that could be opened next to the samples.
    for k in np.setdiff1d(np.arange(labels.max() + 1), owners):
        for r, c in np.argwhere(labels == k):
            trial = mask.copy()
            trial[r, c] = True
            assert helpers.pairs_in_conflict(trial, spacing), (k, r, c)
    # The fill keeps the rule, keeps the samples and leaves nothing else to open.
    filled, again = place_samples(labels, spacing)
    assert np.array_equal(again, samples) and filled[mask].all()
    assert helpers.pairs_in_conflict(filled, spacing) == []
    for r, c in np.argwhere(~filled)[::7]:
        trial = filled.copy()
        trial[r, c] = True
        assert helpers.pairs_in_conflict(trial, spacing)


def test_a_forbidden_centroid_moves_within_its_superpixel_or_is_dropped(helpers):
    from sassi_bench.bundle import MaskSpacing

    spacing = MaskSpacing(np.full((20, 20), 4), np.full((20, 20), 4), 3, 3.0, 3.0)
    labels = np.full((20, 20), 3, np.int32)
    labels[:, :4] = 0  # centroid (10, 2): sampled first; forbids columns 0..6 of rows 8..12
    labels[:, 4:8] = 1  # centroid (10, 6) is forbidden: moves to the nearest free column, 7
    labels[9:12, 8:10] = 2  # wholly inside the windows of the first two: dropped
    mask, samples = place_samples(labels, spacing, fill=False)
    assert helpers.pairs_in_conflict(mask, spacing) == []
    assert samples[0].tolist() == [10, 2]
    assert samples[1, 1] == 7 and samples[1, 0] in (9, 10)
    assert labels[samples[:, 0], samples[:, 1]].tolist() == [0, 1, 3]


def test_segmentation_gives_every_pixel_a_sample_and_follows_edges():
    image = np.zeros((30, 40, 3), np.float32)
    image[:, 20:, 0] = 1.0  # red right half
    samples = np.array([[15, 5], [15, 35], [2, 18]])
    labels = segment_around_samples(image, samples)
    assert labels.min() == 0 and labels.max() == 2
    assert (labels[:, 21:] == 1).mean() > 0.9 and not (labels[:, 21:] == 0).any()
    assert (labels[samples[:, 0], samples[:, 1]] == [0, 1, 2]).all()
    # Sparse samples leave pixels beyond their reach: they take the nearest sample.
    far = segment_around_samples(np.zeros((100, 100), np.float32), [[0, 0], [1, 1]])
    assert far[99, 99] == 1 and far[0, 0] == 0


def test_adaptive_mask_on_a_guide_image(synthetic_bundle, synthetic_spacing, helpers):
    rng = np.random.default_rng(0)
    guide = rng.uniform(0, 4095, (540, 720, 3)).astype(np.float32)
    guide_slm = guide_on_slm(synthetic_bundle, guide)
    assert guide_slm.shape == (*synthetic_bundle.slm_shape, 3)
    result = adaptive_mask(guide_slm, synthetic_spacing)
    assert helpers.pairs_in_conflict(result.mask, synthetic_spacing) == []
    assert result.labels.shape == synthetic_bundle.slm_shape
    assert set(np.unique(result.labels)) == set(range(len(result.samples)))
    assert result.mask.sum() >= len(result.samples) > 50


def test_bad_guide_images_are_refused(synthetic_bundle, synthetic_spacing):
    with pytest.raises(ProcedureError, match=r"guide image has shape \(5, 5, 7\)"):
        guide_on_slm(synthetic_bundle, np.zeros((5, 5, 7)))
    with pytest.raises(ProcedureError, match="warp the guide image onto the SLM grid"):
        adaptive_mask(np.zeros((50, 60, 3), np.float32), synthetic_spacing)
    with pytest.raises(ProcedureError, match="warp the guide image"):
        superpixels(np.zeros((50, 60), np.float32), 10, shape=synthetic_bundle.slm_shape)


def test_a_bundle_without_guide_homography_is_refused(tmp_path, helpers):
    from sassi_bench.bundle import load

    synthetic_models = helpers.models

    bundle = load(
        synthetic_models.publish_synthetic(
            tmp_path, models=synthetic_models.make_models(guide_to_slm=None, guide_info={})
        )
    )
    with pytest.raises(ProcedureError, match=r"no guide -> SLM homography.*Fix: run"):
        guide_on_slm(bundle, np.zeros((540, 720, 3)))
