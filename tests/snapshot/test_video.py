"""The video pipeline: frame after frame, two threads or one, background carried over."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from sassi_bench.snapshot import (
    VideoPipeline,
    check_mask,
    measure_samples,
    rank1_factors,
    segment_around_samples,
)
from sassi_bench.snapshot.video import STEPS

_spec = importlib.util.spec_from_file_location(
    "snapshot_test_measure", Path(__file__).parent / "test_measure.py"
)
TEST_MEASURE = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(TEST_MEASURE)  # its renderer of streaks from the bundle's model


def frames(bundle, seed):
    """A smooth colour guide image and a spectral frame of noise on a smooth background."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[:540, :720] / 90.0
    guide = np.stack([np.sin(xx + seed) + 2, np.cos(yy) + 2, np.sin(xx + yy) + 2], axis=-1)
    cy, cx = np.mgrid[:2048, :2048] / 2048.0
    spectral = rng.poisson(200.0 + 50.0 * cx + 30.0 * cy**2).astype(np.uint16)
    return (1000 * guide).astype(np.float32), spectral


def test_frames_in_two_threads_equal_one_thread_and_the_rule_is_kept(synthetic_bundle):
    spacing = synthetic_bundle.mask_spacing(row_pitch=8)  # dense: streaks overlap
    guide0, _ = frames(synthetic_bundle, 0)
    results = []
    for threads in (2, 1):
        with VideoPipeline(synthetic_bundle, spacing, threads=threads) as pipeline:
            mask, samples = pipeline.plan(guide0)
            out = []
            for seed in (1, 2):
                guide, spectral = frames(synthetic_bundle, seed)
                frame = pipeline.process(guide, spectral, mask, samples, exposure_s=0.1)
                out.append(frame)
                mask, samples = frame.next_mask, frame.next_samples
            results.append(out)
    for two, one in zip(*results, strict=True):
        np.testing.assert_array_equal(two.spectra, one.spectra)
        np.testing.assert_array_equal(two.rank1.dense(), one.rank1.dense())
    first, second = results[0]
    assert set(STEPS) | {"total"} <= set(first.seconds)
    check_mask(first.next_mask, spacing)  # raises if the rule is broken
    assert len(first.next_samples) > 0 and first.next_mask.sum() >= len(first.next_samples)
    # Frame 2 was taken with the mask planned on frame 1's guide image.
    np.testing.assert_array_equal(second.mask, first.next_mask)
    # The rank-1 cube is the one of the frame's own regions and spectra.
    labels = segment_around_samples(second.guide_slm, second.samples)
    expected = rank1_factors(second.guide_slm, labels, second.mask, second.spectra)
    np.testing.assert_array_equal(second.rank1.dense(), expected.dense())


def test_the_carried_background_gives_the_spectra_of_a_fresh_estimate(synthetic_bundle):
    spacing = synthetic_bundle.mask_spacing(row_pitch=8)
    guide, _ = frames(synthetic_bundle, 3)
    with VideoPipeline(synthetic_bundle, spacing) as pipeline:
        mask, samples = pipeline.plan(guide)
        rows, cols = np.nonzero(mask)
        rng = np.random.default_rng(5)
        lam = synthetic_bundle.wavelengths
        peak = rng.uniform(450, 650, rows.size)[:, None]
        spectra = rng.uniform(200, 2000, (rows.size, 1)) * np.exp(-(((lam - peak) / 60.0) ** 2))
        cx = np.tile(np.arange(2048.0) / 2048.0, (2048, 1))
        truth_spectra = spectra / 0.1 / np.asarray(synthetic_bundle.response)
        background = 100.0 + 20.0 * cx
        first = TEST_MEASURE.render(synthetic_bundle, rows, cols, spectra[::-1], background)
        pipeline.process(guide, first, mask, samples, exposure_s=0.1)  # from scratch
        # The next frame: other spectra at the open pixels over the same slow leakage.
        frame = TEST_MEASURE.render(synthetic_bundle, rows, cols, spectra, background)
        warm = pipeline.process(guide, frame, mask, samples, exposure_s=0.1)
    cold, _ = measure_samples(frame, mask, synthetic_bundle, exposure_s=0.1)

    def error(measured):
        return np.sqrt(np.mean((measured - truth_spectra) ** 2)) / np.abs(truth_spectra).max()

    # Two refinements from the last frame's background do as well as 24 from scratch
    # (a sudden change of the leakage would need more: see WARM_BACKGROUND_PASSES).
    assert error(warm.spectra) < 1.1 * error(cold) + 1e-3
    assert error(cold) < 0.05
