"""Cross-column unmixing on synthetic frames: streaks of neighbouring SLM columns, a few
rows apart and shifted along the streak, as a dense snapshot mask lays them."""

import dataclasses

import numpy as np
import pytest
from scipy.special import ndtr

from sassi_bench.spectra.cells import cell_layout
from sassi_bench.spectra.crosstalk import PROFILE_SIGMAS, StreakModel, columns_interact
from sassi_bench.spectra.extract import extract_spectra, extract_with_background
from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.offset import BlockBackground, streak_footprint


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
    assert not cell_layout(geometry, frame.shape).off.any()
    model = StreakModel(geometry, frame.shape)
    spectra = model.bins(model.fit(frame))
    # Least squares on a noise-free frame of the model: exact up to the model's one
    # approximation, a bin's blur and centre row taken for the whole of each camera
    # column it shares with its neighbour (here the centre moves 0.05 rows a bin).
    assert spectra == pytest.approx(window_sum, rel=2e-3)  # worst here: 1.0e-3 at 3.5 px, 5 rows


def test_per_column_unmixing_alone_would_mix_them():
    frame, geometry, _, window_sum = _staggered_frame(2.0, np.random.default_rng(1))
    stacked, _ = extract_spectra(frame, geometry, coupling_floor=0.0)
    assert np.abs(stacked / window_sum - 1).max() > 0.2


def test_streaks_far_apart_do_not_interact():
    _, geometry, _, _ = _staggered_frame(1.0, np.random.default_rng(2), pitch=20)
    assert not columns_interact(geometry)


def _brute_force_render(geometry, light, shape):
    """Each pixel's light per camera column as a Gaussian across the rows (its bins' mean
    centre and sigma in that column, weighted by their fractions there, cut
    ``PROFILE_SIGMAS`` from the centre), pixel by pixel; and which (pixel, column) paint
    anything."""
    height, width = shape
    image = np.zeros(shape)
    painted = np.zeros(light.shape, dtype=bool)
    rows = np.arange(height)
    first = np.floor(geometry.x_left.min(axis=1) + 0.5).astype(int)
    for n in range(geometry.rows.size):  # a test oracle: a few pixels, a few columns
        for k in range(light.shape[1]):
            c = first[n] + k
            cover = np.clip(
                np.minimum(c + 0.5, geometry.x_right[n]) - np.maximum(c - 0.5, geometry.x_left[n]),
                0,
                None,
            )
            if cover.sum() == 0 or not 0 <= c < width:
                continue
            painted[n, k] = True
            y = cover @ geometry.y[n] / cover.sum()
            s = cover @ geometry.sigma[n] / cover.sum()
            # Rows within the model's reach of the centre (its profiles stop there).
            reach = (rows >= np.floor(y - PROFILE_SIGMAS * s - 0.5)) & (
                rows <= np.ceil(y + PROFILE_SIGMAS * s + 0.5)
            )
            share = ndtr((rows + 0.5 - y) / s) - ndtr((rows - 0.5 - y) / s)
            image[:, c] += light[n, k] * np.where(reach, share, 0.0)
    return image, painted


def test_streak_model_renders_fits_and_sums_bins():
    rng = np.random.default_rng(3)
    _, geometry, _, _ = _staggered_frame(1.5, rng, pitch=5, height=100)
    model = StreakModel(geometry, (100, 200))
    light = rng.uniform(1, 2, model.units)
    expected, painted = _brute_force_render(
        geometry, light.reshape(geometry.rows.size, -1), (100, 200)
    )
    assert (~painted).sum() < 0.05 * painted.size  # the padding of the shorter streaks
    light[~painted.ravel()] = 0.0
    image = model.render(light)
    assert image == pytest.approx(expected, abs=1e-6)
    assert model.fit(image) == pytest.approx(light, rel=1e-8, abs=1e-9)
    # Each bin: its columns' light, the end columns by their fraction inside the bin.
    per_pixel = light.reshape(geometry.rows.size, -1)
    first = np.floor(geometry.x_left.min(axis=1) + 0.5).astype(int)
    n, b = 4, 3
    columns = np.arange(per_pixel.shape[1]) + first[n]
    cover = np.clip(
        np.minimum(columns + 0.5, geometry.x_right[n, b])
        - np.maximum(columns - 0.5, geometry.x_left[n, b]),
        0,
        None,
    )
    assert model.bins(light)[n, b] == pytest.approx(cover @ per_pixel[n])


def test_light_beyond_the_frame_is_pinned_to_zero():
    rng = np.random.default_rng(4)
    _, geometry, _, _ = _staggered_frame(1.0, rng, pitch=8, height=120)
    shifted = dataclasses.replace(
        geometry, x_left=geometry.x_left - 62.0, x_right=geometry.x_right - 62.0
    )  # the first streaks start left of the camera
    model = StreakModel(shifted, (120, 200))
    light = model.fit(rng.uniform(0, 1, (120, 200)))
    first = np.floor(shifted.x_left.min(axis=1) + 0.5).astype(int)
    column = first[:, None] + np.arange(light.size // first.size)[None, :]
    assert (column < 0).any()
    assert np.all(light.reshape(column.shape)[column < 0] == 0.0)
    assert np.all(np.isfinite(light))


def test_background_refinement_recovers_the_leakage_under_dense_streaks():
    rng = np.random.default_rng(5)
    frame, geometry, _, window_sum = _staggered_frame(1.5, rng, pitch=5, height=120)
    yy, xx = np.mgrid[:120, :200]
    leakage = 0.05 + 0.04 * np.exp(-((xx - 80.0) ** 2 + (yy - 40.0) ** 2) / (2 * 25.0**2))
    raw = frame + leakage
    first, _, _ = extract_with_background(raw, geometry, block=(8, 8), passes=0)
    refined, _, background = extract_with_background(raw, geometry, block=(8, 8), passes=24)
    error_first, error_refined = np.abs(first - window_sum), np.abs(refined - window_sum)
    # The footprints cover the middle of the leakage bump; the refinements see it through
    # the streaks' residual. Window sums are 2.5 to 5 here: median errors 0.13 before the
    # refinements and 0.021 after, worst 0.19 and 0.055.
    assert np.median(error_refined) < min(0.25 * np.median(error_first), 0.03)
    assert error_refined.max() < 0.4 * error_first.max()
    # Under the streaks (where the spectra need it) the leakage is followed to 0.0008 in
    # the median (of a 0.04 bump), 0.0045 at worst; blocks far from any streak are not
    # refined (the spline carries their first values).
    under = streak_footprint(geometry, raw.shape)
    error_background = np.abs(background.image - leakage)[under]
    assert np.median(error_background) < 1.5e-3
    assert error_background.max() < 6e-3


def test_a_carried_background_follows_a_sudden_change_of_the_leakage():
    rng = np.random.default_rng(6)
    frame, geometry, _, window_sum = _staggered_frame(1.5, rng, pitch=5, height=120)
    yy, xx = np.mgrid[:120, :200]
    leakage = 0.5 + 0.4 * np.exp(-((xx - 80.0) ** 2 + (yy - 40.0) ** 2) / (2 * 25.0**2))
    _, _, carried = extract_with_background(frame + leakage, geometry, block=(8, 8), passes=24)
    switched = frame + 1.2 * leakage  # a light switched on between the frames
    cold, _, _ = extract_with_background(switched, geometry, block=(8, 8), passes=24)
    one, _, _ = extract_with_background(switched, geometry, block=(8, 8), passes=1, start=carried)
    settled, _, _ = extract_with_background(
        switched, geometry, block=(8, 8), passes=1, start=carried, settle=24
    )

    def error(spectra):
        return np.median(np.abs(spectra - window_sum))

    # One pass from the last background leaves much of the jump in the spectra; the jump
    # of the pure background around the streaks sends it on to as many passes as a cold
    # start, which then does as well.
    assert error(one) > 2 * error(cold)
    assert error(settled) < 1.2 * error(cold)


def _dense_design(model, shape):
    """The model's design matrix, column by column (each unit rendered alone)."""
    columns = []
    for u in range(model.units):
        light = np.zeros(model.units)
        light[u] = 1.0
        columns.append(model.render(light).ravel())
    return np.stack(columns, axis=1)


def test_the_column_solves_are_the_least_squares_fit_with_and_without_a_background():
    rng = np.random.default_rng(7)
    _, geometry, _, _ = _staggered_frame(1.2, rng, pitch=4, height=64, width=120)
    shape = (64, 120)
    model = StreakModel(geometry, shape)
    design = _dense_design(model, shape)
    seen = np.abs(design).sum(axis=0) > 0
    image = rng.normal(10.0, 1.0, shape)
    expected = np.zeros(model.units)
    expected[seen] = np.linalg.lstsq(design[:, seen], image.ravel(), rcond=None)[0]
    np.testing.assert_allclose(model.fit(image), expected, rtol=1e-8, atol=1e-9)
    grid = rng.uniform(5.0, 8.0, (8, 8))
    background = BlockBackground.from_values(grid, shape, (8, 16))
    np.testing.assert_allclose(
        model.fit(image, background), model.fit(image - background.image), rtol=1e-9, atol=1e-9
    )
    # Integer frames (a camera's) are read as they are, not copied to float first.
    counts = rng.poisson(50.0, shape).astype(np.uint16)
    np.testing.assert_allclose(model.fit(counts), model.fit(counts.astype(float)), rtol=1e-12)


def test_residual_block_medians_are_numpys_medians_of_what_the_light_leaves():
    rng = np.random.default_rng(8)
    _, geometry, _, _ = _staggered_frame(1.5, rng, pitch=5, height=70, width=150)
    shape = (70, 150)  # 70 rows: the last block row is a partial one (6 rows)
    model = StreakModel(geometry, shape)
    image = rng.normal(100.0, 3.0, shape)
    light = model.fit(image)
    wanted = model.touched_blocks((8, 16))
    assert wanted.any() and not wanted.all()
    out = np.full(wanted.shape, -1.0)
    model.residual_medians(image, light, (8, 16), wanted, out)
    residual = image - model.render(light)
    for i, j in zip(*np.nonzero(wanted), strict=True):
        block = residual[8 * i : 8 * i + 8, 16 * j : 16 * j + 16]
        assert out[i, j] == pytest.approx(np.median(block), abs=2e-5)  # float32 residuals
    assert (out[~wanted] == -1.0).all()
    # The touched blocks are the ones the units' rows reach: everywhere the model paints.
    painted = np.abs(model.render(np.ones(model.units))) > 0
    blocks = np.zeros(wanted.shape, bool)
    rows, cols = np.nonzero(painted)
    blocks[rows // 8, cols // 16] = True
    np.testing.assert_array_equal(blocks, wanted)
