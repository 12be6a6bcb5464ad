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
    bins of 2.5 columns each. Built pixel by pixel, independently of the extraction.

    Returns the frame, the geometry, each bin's light and each bin's *window sum*: the
    light of the pixel's streak in the bin's camera columns, the end columns by their
    fraction inside the bin (what extraction measures before the within-streak deblur:
    a column shared by two bins holds light of both)."""
    n, bins, width_bin = 12, 8, 2.5
    rows = np.arange(n) * pitch + 10
    cols = np.arange(n) + 40
    x_left = 60.3 + shift * np.arange(n)[:, None] + width_bin * np.arange(bins)[None, :]
    x_right = x_left + width_bin
    y = np.repeat((rows * 1.08 + 5.0)[:, None], bins, 1) + 0.05 * np.arange(bins)[None, :]
    amplitude = rng.uniform(1, 2, (n, bins))
    yy, xx = np.arange(height), np.arange(width)
    frame = np.zeros((height, width))
    window_sum = np.zeros((n, bins))
    for p in range(n):  # a test fixture: loops over a hundred synthetic boxes
        column_light = np.zeros(width)
        cover = np.clip(
            np.minimum(xx + 0.5, x_right[p][:, None]) - np.maximum(xx - 0.5, x_left[p][:, None]),
            0,
            None,
        )  # (bins, width): each column's fraction inside each bin
        for b in range(bins):
            profile = ndtr((yy + 0.5 - y[p, b]) / sigma) - ndtr((yy - 0.5 - y[p, b]) / sigma)
            frame += amplitude[p, b] * np.outer(profile, cover[b] / width_bin)
            column_light += amplitude[p, b] * cover[b] / width_bin
        window_sum[p] = cover @ column_light
    geometry = StreakGeometry(rows, cols, x_left, x_right, y, np.full(bins, sigma), guard=0)
    return frame, geometry, amplitude, window_sum


@pytest.mark.parametrize(("sigma", "pitch"), [(1.0, 5), (2.0, 5), (3.5, 8), (3.5, 5)])
def test_streaks_of_neighbouring_columns_are_separated(sigma, pitch):
    rng = np.random.default_rng(0)
    frame, geometry, _, window_sum = _staggered_frame(sigma, rng, pitch=pitch, height=160)
    assert columns_interact(geometry)
    spectra, off = extract_spectra(frame, geometry, coupling_floor=0.0, cross_columns=True)
    assert not off.any()
    # Least squares on a noise-free frame of the model: exact up to the model's one
    # approximation, a bin's blur and centre row taken for the whole of each camera
    # column it shares with its neighbour (here the centre moves 0.05 rows a bin).
    assert spectra == pytest.approx(window_sum, rel=2e-3)  # worst here: 1.0e-3 at 3.5 px, 5 rows
    # Auto-detection takes the same path.
    auto, _ = extract_spectra(frame, geometry, coupling_floor=0.0, cross_columns=None)
    assert auto == pytest.approx(spectra, rel=1e-9)


def test_per_column_unmixing_alone_would_mix_them():
    frame, geometry, _, window_sum = _staggered_frame(2.0, np.random.default_rng(1))
    stacked, _ = extract_spectra(frame, geometry, coupling_floor=0.0, cross_columns=False)
    assert np.abs(stacked / window_sum - 1).max() > 0.2


def test_streaks_far_apart_do_not_interact():
    _, geometry, _, _ = _staggered_frame(1.0, np.random.default_rng(2), pitch=20)
    assert not columns_interact(geometry)
