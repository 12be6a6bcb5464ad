"""The noise model's compiled variance and fused cell sums against the numpy forms."""

import numpy as np
import pytest

from sassi_bench.spectra.cells import CellLayout, cell_sums, column_cumsum
from sassi_bench.spectra.noise import CountsNoise, column_weights


def _numpy_variance(noise: CountsNoise, raw_sums, layout: CellLayout, row_gain):
    """The numpy form the compiled variance replaced."""
    total, square = column_weights(layout)
    rows = layout.bottom - layout.top
    above_dark = np.clip(raw_sums - noise.dark_offset_adu * rows * total, 0.0, None)
    share = np.divide(square, total, out=np.zeros_like(total), where=total > 0)
    photons = share * above_dark / noise.gain_e_per_adu
    return (photons + rows * square * noise.read_noise_adu**2) * np.asarray(row_gain)


def _layout(rng, shape=(60, 80), pixels=300, bins=9) -> CellLayout:
    """Cells of every kind: inside the frame, across its edges, empty and whole-column."""
    h, w = shape
    x_left = rng.uniform(-4.0, w + 2.0, (pixels, bins))
    x_left[:50] = np.round(x_left[:50]) - 0.5  # bounds on column edges
    x_right = x_left + rng.uniform(0.0, 6.0, x_left.shape)
    x_right[:20] = np.round(x_right[:20]) + 0.5
    x_right[0, 0] = x_left[0, 0]  # an empty bin
    lo = rng.uniform(-6.0, h + 3.0, (pixels, bins))
    hi = lo + rng.uniform(0.0, 9.0, lo.shape)
    off = np.zeros(lo.shape, dtype=bool)
    return CellLayout(lo, hi, off, np.zeros((1, 1), np.intp), x_left, x_right, shape)


@pytest.mark.parametrize("raw_dtype", [np.float32, np.float64])
def test_compiled_variance_is_the_numpy_form_to_the_bit(raw_dtype):
    rng = np.random.default_rng(3)
    layout = _layout(rng)
    noise = CountsNoise(0.4585, 6.543, 100.0)
    raw = rng.uniform(-500.0, 60000.0, layout.lo.shape).astype(raw_dtype)
    row_gain = rng.uniform(1.0, 5.0, layout.lo.shape[1])
    expected = _numpy_variance(noise, raw, layout, row_gain)
    got = noise.variance(raw, layout, row_gain)
    total, _ = column_weights(layout)
    assert (total == 0).any() and (total > 0).any()  # empty and lit cells both tested
    assert np.array_equal(got.view(np.int64), expected.view(np.int64))


def test_fused_cell_sums_are_the_two_passes_to_the_bit():
    rng = np.random.default_rng(4)
    layout = _layout(rng)
    image = rng.integers(0, 65535, layout.shape).astype(np.uint16)
    cumulative = column_cumsum(image)
    noise = CountsNoise(0.4585, 6.543, 100.0)
    row_gain = rng.uniform(1.0, 5.0, layout.lo.shape[1])
    expected_sums = cell_sums(cumulative, layout).astype(np.float32)
    expected_variance = _numpy_variance(noise, expected_sums, layout, row_gain)
    sums, variance = noise.cell_sums(cumulative, layout, row_gain)
    assert sums.dtype == np.float32 and (expected_sums > 0).any()
    assert np.array_equal(sums.view(np.int32), expected_sums.view(np.int32))
    assert np.array_equal(variance.view(np.int64), expected_variance.view(np.int64))


def test_neighbour_covariance_matches_a_monte_carlo_of_the_pixels():
    # Bins 0.4-1.6 columns wide (the red end's are narrower than a column, so a column
    # holds up to three), light uniform across the cells as the model takes it.
    rng = np.random.default_rng(5)
    noise = CountsNoise(0.5, 3.0, 100.0)
    edges = 3.3 + np.cumsum(np.r_[0.0, rng.uniform(0.4, 1.6, 12)])
    bins = edges.size - 1
    layout = CellLayout(
        np.full((1, bins), 1.5), np.full((1, bins), 7.5), np.zeros((1, bins), bool),
        np.zeros((1, 1), np.intp), edges[None, :-1], edges[None, 1:], (10, 20),
    )  # fmt: skip
    electrons = 800.0
    draws = 4000
    frames = 100.0 + (
        rng.poisson(electrons, (draws, 10, 20)) / noise.gain_e_per_adu
        + rng.normal(0.0, noise.read_noise_adu, (draws, 10, 20))
    )
    sums = np.array([cell_sums(column_cumsum(f), layout)[0] for f in frames])
    mean = sums.mean(axis=0, keepdims=True)
    gain = np.ones(bins)
    measured = np.cov(sums.T)
    variance = noise.variance(mean, layout, gain)[0]
    covariance = noise.neighbour_covariance(mean, layout, gain)[0]
    assert np.allclose(variance, np.diag(measured), rtol=0.08)
    for k in (1, 2):
        shared = covariance[k - 1, :-k] > 0
        assert shared.sum() >= 3 if k == 1 else shared.any()
        scale = np.sqrt(variance[:-k] * variance[k:])  # errors judged as correlations
        error = (covariance[k - 1, :-k] - np.diag(measured, k)) / scale
        assert np.all(np.abs(error) <= 0.05), error.round(3)  # the draws' own: about 0.016
        assert np.all(np.abs(np.diag(measured, k)[~shared] / scale[~shared]) <= 0.05)
