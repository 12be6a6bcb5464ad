"""Spectrum extraction on synthetic frames built from the extraction's own model."""

import numpy as np
import pytest
from scipy.special import ndtr

from sassi_bench.maths.normal import box_overlap
from sassi_bench.spectra.cells import NEGLIGIBLE_COUPLING
from sassi_bench.spectra.extract import extract_spectra
from sassi_bench.spectra.geometry import StreakGeometry


def _stacked_frame(sigma, rng, height=120, width=200, pitch=5):
    """Two SLM columns of six pinholes each (``pitch`` rows apart), five one-column bins."""
    rows = np.repeat(np.arange(6) * pitch + 10, 2)
    cols = np.tile([20, 120], 6)
    bins = 5
    x_left = cols[:, None] + 29.5 + np.arange(bins)[None, :]
    y = np.repeat((rows * 1.08 + 5.0)[:, None], bins, 1)
    amplitude = rng.uniform(1, 2, (rows.size, bins))
    yy = np.arange(height)
    frame = np.zeros((height, width))
    for n in range(rows.size):  # a test fixture: loops over a dozen synthetic spots
        for b in range(bins):
            profile = ndtr((yy + 0.5 - y[n, b]) / sigma) - ndtr((yy - 0.5 - y[n, b]) / sigma)
            frame[:, int(x_left[n, b] + 0.5)] += amplitude[n, b] * profile
    geometry = StreakGeometry(rows, cols, x_left, x_left + 1, y, np.full(bins, sigma), guard=0)
    return frame, geometry, amplitude


@pytest.mark.parametrize("sigma", [0.5, 2.0, 3.5])
def test_overlapping_pinholes_of_a_column_are_separated(sigma):
    frame, geometry, amplitude = _stacked_frame(sigma, np.random.default_rng(0))
    spectra, off = extract_spectra(frame, geometry, coupling_floor=0.0)
    assert not off.any()
    assert spectra == pytest.approx(amplitude, rel=1e-6)
    # Neglecting couplings under the floor costs at most the floor (times the
    # neighbours' amplitude ratio, here <= 2).
    default, _ = extract_spectra(frame, geometry)
    assert default == pytest.approx(amplitude, rel=2 * NEGLIGIBLE_COUPLING)


def test_pinholes_closer_than_their_blur_are_separated():
    # At a 2 px pitch and sigma 3.5 px a pixel keeps less light in its cell than its
    # neighbours put there: the systems are not diagonally dominant and need pivoting.
    frame, geometry, amplitude = _stacked_frame(3.5, np.random.default_rng(2), pitch=2)
    spectra, _ = extract_spectra(frame, geometry, coupling_floor=0.0)
    assert spectra == pytest.approx(amplitude, rel=1e-6)


def test_plain_window_sums_would_mix_neighbours():
    # The reason for the banded solve: at sigma 3.5 px a 5.4 px pitch mixes rows.
    frame, geometry, amplitude = _stacked_frame(3.5, np.random.default_rng(1))
    cell = frame[:, int(geometry.x_left[4, 2] + 0.5)]
    y = geometry.y[4, 2]
    naive = cell[int(np.ceil(y - 2.7)) : int(np.ceil(y + 2.7))].sum()
    assert abs(naive / amplitude[4, 2] - 1) > 0.05


def test_spill_matrix_conserves_light_of_interior_bins():
    edges = np.arange(30.0)
    sigma = np.full(29, 1.5)
    a = box_overlap(edges[:-1], edges[1:], sigma)
    assert a[:, 10:19].sum(axis=0) == pytest.approx(1.0, abs=1e-9)
    assert a[10, 10] < 0.5  # at 1.5 px blur most of a 1 px bin spills out
