import numpy as np
import pytest

from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.offset import (
    BlockBackground,
    block_values,
    estimate_background,
    fill_block_grid,
    first_block_estimate,
    streak_footprint,
)


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


def test_holes_are_filled_linearly_from_the_nearer_known_blocks():
    from sassi_bench.spectra import _offset_kernels

    values = np.add.outer(10.0 * np.arange(5), np.arange(7.0))  # a plane on the block grid
    holes = values.copy()
    holes[1:4, 2:5] = np.nan
    holes[4, :] = np.nan  # a block row with no known block
    while not np.isfinite(holes).all():
        _offset_kernels.fill_holes(holes, 8, 16)
    np.testing.assert_allclose(holes[:4], values[:4], atol=1e-3)  # linear both ways: a plane
    # Beyond the last known block of a column: that block's value.
    np.testing.assert_allclose(holes[4, [0, 1, 5, 6]], values[3, [0, 1, 5, 6]])
    np.testing.assert_allclose(holes[4, 2:5], values[0, 2:5])


def test_thin_free_bands_between_streak_rows_give_the_background():
    """Under a dense mask only thin bands of rows between the streaks are free: a block
    with 6 of its 128 pixels free still gives a median, so the background follows the
    bands' level changes instead of being interpolated over the streaks."""
    rng = np.random.default_rng(0)
    yy, xx = np.mgrid[0:96, 0:256]
    background = 100.0 + 300.0 * (yy >= 48) + 0.2 * xx  # a scene edge between two bands
    streaks = (yy % 16) >= 2  # 2 free rows in every 16
    frame = background + 800.0 * streaks + rng.normal(0, 1.0, background.shape)
    estimate = estimate_background(frame, streaks)
    # Away from the edge (the spline rings next to it) the level of each band is found.
    for rows in (slice(4, 24), slice(72, 92)):
        assert np.abs(estimate.image[rows] - background[rows]).max() < 10.0


def test_a_block_background_is_the_estimates_spline_surface():
    """Kept as coefficients, the surface through the block medians is the one
    estimate_background builds (FITPACK's interpolating spline), for any lattice."""
    rng = np.random.default_rng(4)
    for shape in [(721, 300), (40, 33), (17, 50), (9, 40)]:
        frame = rng.normal(100.0, 2.0, shape) + np.add.outer(
            np.sin(np.arange(shape[0]) / 30.0), np.cos(np.arange(shape[1]) / 90.0)
        )
        free = np.zeros(shape, bool)
        expected = estimate_background(frame, free).image
        surface = BlockBackground.from_values(block_values(frame, (8, 16)), shape, (8, 16))
        np.testing.assert_allclose(surface.image, expected, atol=1e-9)
    # One block: a constant.
    flat = BlockBackground.from_values([[3.0]], (5, 7), (8, 16))
    np.testing.assert_array_equal(flat.image, np.full((5, 7), 3.0))


def test_block_grids_are_checked_and_their_holes_filled():
    with pytest.raises(ValueError, match="expected"):
        BlockBackground.from_values(np.zeros((3, 3)), (24, 64), (8, 16))
    with pytest.raises(ValueError, match="no block"):
        fill_block_grid(np.full((2, 2), np.nan), (8, 16))
    grid = np.array([[1.0, np.nan, 3.0], [np.nan, np.nan, np.nan]])
    background = BlockBackground.from_values(grid, (16, 48), (8, 16))
    np.testing.assert_allclose(background.values, [[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]])
    assert np.isnan(grid).sum() == 4  # the caller's grid is left as it was


def test_the_first_estimate_takes_the_free_pixels_of_the_wanted_blocks_only():
    rng = np.random.default_rng(5)
    geometry = StreakGeometry(
        np.array([0]), np.array([0]), np.array([[40.0]]), np.array([[60.0]]),
        np.array([[20.0]]), np.array([1.0]), guard=0,
    )  # fmt: skip
    frame = rng.normal(50.0, 1.0, (40, 96))
    footprint = streak_footprint(geometry, frame.shape)
    frame[footprint] += 1000.0  # the streak: not background
    wanted = np.zeros((5, 6), bool)
    wanted[1:4, 1:5] = True
    estimate = first_block_estimate(frame, geometry, (8, 16), wanted)
    assert np.isnan(estimate[~wanted]).all()
    full = block_values(frame, (8, 16), footprint)
    np.testing.assert_array_equal(estimate[wanted], full[wanted])
    assert np.nanmax(np.abs(estimate - 50.0)) < 2.0  # the streak's light is not in it
