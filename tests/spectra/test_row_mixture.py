"""The mixed-blur row unmixing against the exact forward model of a stacked column."""

import numpy as np
import pytest
from scipy.special import ndtr

from sassi_bench.spectra import _mixture_kernels
from sassi_bench.spectra.cells import cell_layout, unmix_rows
from sassi_bench.spectra.forward import StreakForwardModel, spill_matrix
from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.row_mixture import RowMixture, unmix_rows_mixed

PITCH = 5.4  # camera rows between stacked pinholes, as on `sim`


def _column(sigma, rng, stack=12):
    """A stacked SLM column of 1-px bins whose blur is ``sigma[k]`` along and across the
    streak, its exact cell sums, the column sums they should unmix to, and the spectra."""
    bins = sigma.size
    x_left = np.tile(100.0 + np.arange(bins), (stack, 1))
    y = 30.0 + PITCH * np.arange(stack)[:, None] + 0.01 * np.arange(bins)  # a slight smile
    geo = StreakGeometry(
        np.arange(stack) * 5, np.zeros(stack, np.intp), x_left, x_left + 1.0, y, sigma, guard=0
    )
    spill = spill_matrix(x_left[0], x_left[0] + 1.0, sigma)  # C[b, k]
    model = StreakForwardModel(
        np.zeros(1), np.zeros(1), np.zeros((1, bins)), sigma[None], spill[None], guard=0
    )
    k = np.arange(bins)
    edge = rng.uniform(2, bins - 2, (stack, 1))
    spectra = 0.2 + rng.uniform(0, 1, (stack, 1)) / (1 + np.exp(-(k - edge) / 1.5))
    spectra *= 1e4
    layout = cell_layout(geo, (200, 300))
    sums = np.zeros((stack, bins))
    for cell in range(stack):  # every source pixel and bin, each with its own blur
        top, bottom = layout.lo[cell][:, None], layout.hi[cell][:, None]
        for s in range(stack):
            share = ndtr((bottom - y[s]) / sigma) - ndtr((top - y[s]) / sigma)
            sums[cell] += (spill * share) @ spectra[s]
    return geo, layout, model, sums, spectra @ spill.T, spectra


def _error(amplitudes, expected):
    """RMS error relative to each pixel's peak."""
    return float(
        np.sqrt((((amplitudes - expected) / expected.max(axis=1, keepdims=True)) ** 2).mean())
    )


def test_red_end_column_is_unmixed_with_its_mixed_blur():
    # The red end on `sim`: 1-px bins whose blur grows 9 % a bin, 1.1 -> 3.9 px.
    sigma = 1.07 * 1.09 ** np.arange(16)
    geo, layout, model, sums, expected, spectra = _column(sigma, np.random.default_rng(3))
    mixture = RowMixture.from_model(model)
    separable = unmix_rows(sums, layout, geo, floor=1e-7)
    mixed = unmix_rows_mixed(sums, layout, geo, mixture, floor=1e-7)
    # The single-blur model is off by percents of the peak; the mixture from the
    # first-pass column sums is several times closer.
    assert _error(separable, expected) > 0.01
    assert _error(mixed, expected) < 0.25 * _error(separable, expected)
    # With the true spectra as the estimate, only the quadrature and the mean centre
    # of the mixture remain.
    oracle = unmix_rows_mixed(sums, layout, geo, mixture, first=spectra, floor=1e-7)
    assert _error(oracle, expected) < 1e-3


def test_one_blur_for_all_bins_leaves_the_separable_unmixing():
    sigma = np.full(10, 2.5)
    geo, layout, model, sums, _, _ = _column(sigma, np.random.default_rng(4))
    geo = StreakGeometry(
        geo.rows, geo.cols, geo.x_left, geo.x_right, np.repeat(geo.y[:, :1], 10, 1), sigma, 0
    )
    layout = cell_layout(geo, (200, 300))
    separable = unmix_rows(sums, layout, geo, floor=1e-7)
    mixture = RowMixture.from_model(model)
    assert mixture.mixed_bins(layout, geo).size == 0
    # Forced through the mixture (every bin), one blur gives the same systems.
    mixed = unmix_rows_mixed(sums, layout, geo, mixture, floor=1e-7, mixing=-1.0)
    np.testing.assert_allclose(mixed, separable, rtol=1e-9, atol=1e-9 * np.abs(sums).max())


@pytest.mark.parametrize("count", [1, 2, 3, 7])
def test_blur_nodes_match_the_moments_of_the_mixture(count):
    rng = np.random.default_rng(count)
    sigma = np.sort(rng.uniform(1.0, 5.0, count))[None]
    spill = rng.uniform(0.1, 1.0, (1, 1, count))
    estimate = rng.uniform(0.0, 2.0, (1, count))
    y = rng.normal(0.0, 0.1, (1, count))
    nodes = np.empty(7)
    _mixture_kernels.blur_nodes(
        spill, sigma, y, np.array([0]), np.array([count]), estimate, 0, 0, 0, nodes
    )
    weight = spill[0, 0] * estimate[0]
    weight /= weight.sum()
    w, s = nodes[0:6:2], nodes[1:6:2]
    # Exact up to the fifth moment (as far as the measure has distinct points).
    for power in range(min(2 * count, 6)):
        assert (w * s**power).sum() == pytest.approx((weight * sigma[0] ** power).sum(), rel=1e-9)
    assert nodes[6] == pytest.approx((weight * y[0]).sum())
