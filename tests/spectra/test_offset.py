import numpy as np
import pytest

from sassi_bench.spectra.extract import StreakGeometry
from sassi_bench.spectra.offset import estimate_background, streak_footprint


def test_footprint_covers_the_streaks_and_their_blur():
    geometry = StreakGeometry(
        np.array([0, 5]), np.array([0, 0]),
        np.array([[10.0, 11.0], [10.0, 11.0]]), np.array([[11.0, 12.0], [11.0, 12.0]]),
        np.array([[20.0, 20.0], [26.0, 26.0]]), np.array([1.0, 1.0]), guard=0,
    )  # fmt: skip
    mask = streak_footprint(geometry, (40, 40), reach_sigmas=2, margin_px=1)
    rows, cols = np.nonzero(mask)
    assert rows.min() == 18 and rows.max() == 28
    assert cols.min() == 7 and cols.max() == 15


def test_smooth_background_is_recovered_from_the_free_pixels():
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[0:120, 0:200]
    background = 100 + 40 * np.sin(xx / 150.0) + 0.2 * yy
    streaks = np.zeros_like(background, dtype=bool)
    streaks[:, 40:80] = True
    streaks[:, 130:170] = True
    frame = background + 500.0 * streaks + rng.normal(0, 2.0, background.shape)
    estimate = estimate_background(frame, streaks)
    assert np.abs(estimate.image - background).max() < 3.0
    assert estimate.residual_rms == pytest.approx(2.0, rel=0.3)


def test_no_free_pixel_is_a_clear_error():
    with pytest.raises(ValueError, match="no background pixels"):
        estimate_background(np.zeros((20, 20)), np.ones((20, 20), bool))
