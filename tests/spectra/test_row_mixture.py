"""The mixed-blur row unmixing against the exact forward model of a stacked column."""

import numpy as np
import pytest
from scipy.special import ndtr

from sassi_bench.maths.normal import NORMAL_CDF_TABLE, box_overlap
from sassi_bench.spectra import _mixture_kernels
from sassi_bench.spectra.cells import cell_layout, unmix_rows
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.row_mixture import RowMixture, unmix_rows_mixed

PITCH = 5.4  # camera rows between stacked pinholes, as on `sim`


def _column(sigma, rng, stack=12, along=None):
    """A stacked SLM column of 1-px bins whose blur is ``sigma[k]`` across the streak (and
    along it, unless ``along`` is given), its exact cell sums, the column sums they should
    unmix to, and the spectra."""
    bins = sigma.size
    x_left = np.tile(100.0 + np.arange(bins), (stack, 1))
    y = 30.0 + PITCH * np.arange(stack)[:, None] + 0.01 * np.arange(bins)  # a slight smile
    geo = StreakGeometry(
        np.arange(stack) * 5, np.zeros(stack, np.intp), x_left, x_left + 1.0, y, sigma, guard=0
    )
    along = sigma if along is None else along
    spill = box_overlap(x_left[0], x_left[0] + 1.0, along)  # C[b, k]
    model = StreakForwardModel(
        np.zeros(1), np.zeros(1), np.zeros((1, bins)), along[None], spill[None], guard=0
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
    assert mixture.mixed_bins(geo).size == 0
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


def test_mixture_nodes_are_the_nodes_of_each_pixel_and_bin():
    # Staged over bins, the nodes are those of blur_nodes one (pixel, bin) at a time,
    # including one-blur, two-blur and no-estimate mixtures.
    rng = np.random.default_rng(7)
    pixels, bins, points = 9, 12, 2
    spill = rng.uniform(0.0, 1.0, (points, bins, bins))
    sigma = rng.uniform(1.0, 4.0, (points, bins))
    sigma[:, 3:5] = 2.0  # bin 4's sources 3..5: two distinct blurs
    y = rng.normal(20.0, 0.5, (pixels, bins))
    first = np.maximum(np.arange(bins) - 3, 0)
    stop = np.minimum(np.arange(bins) + 4, bins)
    first[4], stop[4] = 3, 6
    first[7], stop[7] = 7, 8  # one source
    estimate = rng.uniform(-0.5, 2.0, (pixels, bins))
    estimate[2] = 0.0  # nothing seen: the spill alone
    points_of = rng.integers(0, points, pixels)
    chosen = np.array([0, 4, 5, 7, 11])
    nodes = np.empty((pixels, chosen.size, 7))
    widest = np.empty(chosen.size)
    args = (spill, sigma, y, first, stop)
    _mixture_kernels.mixture_nodes(points_of, *args, chosen, estimate, nodes, widest)
    expected = np.empty(7)
    for n in range(pixels):
        for j, b in enumerate(chosen):
            _mixture_kernels.blur_nodes(*args, estimate, n, points_of[n], b, expected)
            np.testing.assert_array_equal(nodes[n, j], expected)
    assert (nodes[:, 3, 2] == 0).all() and (nodes[:, 1, 4] == 0).all()  # 1 and 2 nodes
    np.testing.assert_array_equal(
        widest, np.where(nodes[..., 0:6:2] > 0, nodes[..., 1:6:2], 0).max(axis=(0, 2))
    )


@pytest.mark.parametrize("pitch", [PITCH, 2.0, 30.0])
def test_mixed_systems_match_dense_solves(pitch):
    # Against dense systems of exact Gaussian integrals: touching cells (the usual
    # pitch), a pitch finer than the blur (systems that are not diagonally dominant) and
    # cells cut at 3 sigma (gaps between cells, no edge shared).
    rng = np.random.default_rng(11)
    stack, bins = 6, 5
    sigma = np.linspace(1.2, 3.0, bins)
    rows = np.r_[np.arange(stack), np.arange(stack - 2)]  # two SLM columns, one shorter
    cols = np.r_[np.zeros(stack, np.intp), np.ones(stack - 2, np.intp)]
    x_left = np.tile(50.0 + np.arange(bins), (rows.size, 1))
    y = 20.0 + pitch * rows[:, None] + rng.normal(0.0, 0.1, (rows.size, bins))
    geo = StreakGeometry(rows * 5, cols, x_left, x_left + 1.0, y, sigma, guard=0)
    layout = cell_layout(geo, (400, 300))
    chosen = np.array([1, 2, 4])
    nodes = np.zeros((rows.size, chosen.size, 7))
    nodes[..., 0:6:2] = rng.dirichlet(np.ones(3), (rows.size, chosen.size))
    nodes[:, 0, 4] = 0.0  # a two-node mixture
    nodes[:, 0, 0:4:2] /= nodes[:, 0, 0:4:2].sum(axis=1, keepdims=True)
    nodes[..., 1:6:2] = sigma[chosen][None, :, None] * rng.uniform(0.8, 1.3, (1, 1, 3))
    nodes[..., 6] = y[:, chosen] + rng.normal(0.0, 0.05, (rows.size, chosen.size))
    reach = np.array([2, 3, stack - 1])
    sums = rng.uniform(0.0, 1e4, (rows.size, bins))
    out = np.full((rows.size, bins), -1.0)
    _mixture_kernels.unmix_mixed(
        sums, layout.lo, layout.hi, layout.index, chosen, reach, nodes, NORMAL_CDF_TABLE, out
    )
    assert (out[:, [0, 3]] == -1.0).all()  # other bins untouched
    for group in layout.index:
        members = group[group >= 0]
        for j, b in enumerate(chosen):
            a = np.zeros((members.size, members.size))
            for s, n in enumerate(members):
                for t, m in enumerate(members):
                    if abs(s - t) <= reach[j]:
                        w, width, centre = nodes[m, j, 0:6:2], nodes[m, j, 1:6:2], nodes[m, j, 6]
                        share = ndtr((layout.hi[n, b] - centre) / width)
                        share -= ndtr((layout.lo[n, b] - centre) / width)
                        a[s, t] = (w * share).sum()
            expected = np.linalg.solve(a, sums[members, b])
            scale = np.abs(expected).max()
            np.testing.assert_allclose(out[members, b], expected, rtol=0, atol=1e-8 * scale)


def test_a_spot_that_is_not_round_is_mixed_with_its_widths_across_the_streak():
    # A design's spot: the red end's growth across the streak, narrower along it.
    across = 1.07 * 1.09 ** np.arange(16)
    along = 0.7 * across
    geo, layout, _, sums, expected, _ = _column(across, np.random.default_rng(3), along=along)
    spill = box_overlap(geo.x_left[0], geo.x_right[0], along)
    model = StreakForwardModel(
        np.zeros(1), np.zeros(1), np.zeros((1, 16)), along[None], spill[None], guard=0,
        sigma_across_px=across[None],
    )  # fmt: skip
    np.testing.assert_array_equal(model.row_sigma_px, across[None])
    mixed = unmix_rows_mixed(sums, layout, geo, RowMixture.from_model(model), floor=1e-7)
    # The sources mixed with their widths along the streak instead (what a round spot's
    # forward model gives) leave the neighbours' light in the cells.
    round_model = StreakForwardModel(
        np.zeros(1), np.zeros(1), np.zeros((1, 16)), along[None], spill[None], guard=0
    )
    np.testing.assert_array_equal(round_model.row_sigma_px, along[None])
    wrong = unmix_rows_mixed(sums, layout, geo, RowMixture.from_model(round_model), floor=1e-7)
    assert _error(mixed, expected) < 0.008  # measured 0.0047 of the peak (RMS)
    assert _error(wrong, expected) > 0.066  # measured 0.13 (the separable unmixing: 0.049)
