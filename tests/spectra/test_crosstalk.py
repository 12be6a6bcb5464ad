"""Cross-column unmixing on synthetic frames: streaks of neighbouring SLM columns, a few
rows apart and shifted along the streak, as a dense snapshot mask lays them."""

import numpy as np
import pytest
from scipy.special import ndtr

from sassi_bench.spectra.crosstalk import columns_interact
from sassi_bench.spectra.extract import StreakGeometry, extract_spectra


def _staggered_frame(sigma, rng, shift=1.3, pitch=5, height=120, width=200):
    """Twelve pixels whose SLM columns step by one every row of pixels (``pitch`` rows
    apart), so each streak is ``shift`` camera columns along from the one above; eight
    bins of 2.5 columns each. Built pixel by pixel, independently of the extraction."""
    n, bins, width_bin = 12, 8, 2.5
    rows = np.arange(n) * pitch + 10
    cols = np.arange(n) + 40
    x_left = 60.3 + shift * np.arange(n)[:, None] + width_bin * np.arange(bins)[None, :]
    x_right = x_left + width_bin
    y = np.repeat((rows * 1.08 + 5.0)[:, None], bins, 1) + 0.05 * np.arange(bins)[None, :]
    amplitude = rng.uniform(1, 2, (n, bins))
    yy, xx = np.arange(height), np.arange(width)
    frame = np.zeros((height, width))
    for p in range(n):  # a test fixture: loops over a hundred synthetic boxes
        for b in range(bins):
            profile = ndtr((yy + 0.5 - y[p, b]) / sigma) - ndtr((yy - 0.5 - y[p, b]) / sigma)
            cover = np.clip(
                np.minimum(xx + 0.5, x_right[p, b]) - np.maximum(xx - 0.5, x_left[p, b]), 0, None
            )
            frame += amplitude[p, b] * np.outer(profile, cover / width_bin)
    geometry = StreakGeometry(rows, cols, x_left, x_right, y, np.full(bins, sigma), guard=0)
    return frame, geometry, amplitude


@pytest.mark.parametrize(("sigma", "pitch"), [(1.0, 5), (2.0, 5), (3.5, 8)])
def test_streaks_of_neighbouring_columns_are_separated(sigma, pitch):
    # (At sigma 3.5 px and a 5 px pitch the systems are too ill-conditioned for the solver's
    # 60 iterations; the sim rig's reddest bins have that blur, hence a pitch from the blur.)
    rng = np.random.default_rng(0)
    frame, geometry, amplitude = _staggered_frame(sigma, rng, pitch=pitch, height=160)
    assert columns_interact(geometry)
    spectra, off = extract_spectra(frame, geometry, coupling_floor=0.0, cross_columns=True)
    assert not off.any()
    # The solver stops at a relative residual of 1e-6 or after 60 iterations: errors of a
    # few 1e-5 at sigma <= 2 px, 4e-3 at 3.5 px (the per-column solve alone: 240 %).
    assert spectra == pytest.approx(amplitude, rel=1e-4 if sigma <= 2 else 1e-2)
    # Auto-detection takes the same path.
    auto, _ = extract_spectra(frame, geometry, coupling_floor=0.0, cross_columns=None)
    assert auto == pytest.approx(spectra, rel=1e-9)


def test_per_column_unmixing_alone_would_mix_them():
    frame, geometry, amplitude = _staggered_frame(2.0, np.random.default_rng(1))
    stacked, _ = extract_spectra(frame, geometry, coupling_floor=0.0, cross_columns=False)
    assert np.abs(stacked / amplitude - 1).max() > 0.2


def test_streaks_far_apart_do_not_interact():
    _, geometry, _ = _staggered_frame(1.0, np.random.default_rng(2), pitch=20)
    assert not columns_interact(geometry)
