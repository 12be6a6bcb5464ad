"""Cells: column cumulative sums, cell sums, the deblur and the geometry helpers."""

import numpy as np
import pytest

from sassi_bench.bundle import load
from sassi_bench.maths.normal import box_overlap
from sassi_bench.spectra.cells import cell_layout, cell_sums, column_cumsum, unmix_rows
from sassi_bench.spectra.deblur import PIXEL_GUARD_WEIGHT, SpectralDeblur
from sassi_bench.spectra.geometry import StreakGeometry, reached_rows, streak_geometry
from sassi_bench.spectra.priors import SmoothnessPrior


@pytest.mark.parametrize("dtype", [np.uint16, np.float64])
def test_column_cumsum_matches_numpy(dtype):
    image = np.random.default_rng(0).integers(0, 65535, (37, 23)).astype(dtype)
    expected = np.vstack([np.zeros((1, 23)), np.cumsum(image, axis=0, dtype=np.float64)])
    assert np.array_equal(column_cumsum(image), expected)


def test_cell_sums_match_direct_sums():
    rng = np.random.default_rng(1)
    image = rng.normal(size=(30, 40))
    geo = StreakGeometry(
        rows=np.array([0, 5]),
        cols=np.array([2, 2]),
        x_left=np.array([[10.3, 12.1], [10.6, 11.9]]),
        x_right=np.array([[12.1, 13.0], [11.9, 14.2]]),
        y=np.array([[8.2, 8.4], [13.6, 13.9]]),
        sigma=np.array([1.0, 2.0]),
        guard=0,
    )
    layout = cell_layout(geo, image.shape)
    sums = cell_sums(column_cumsum(image), layout)
    cols = np.arange(40)
    for n in range(2):  # a test oracle: a loop over four cells
        for b in range(2):
            weight = np.clip(
                np.minimum(cols + 0.5, geo.x_right[n, b])
                - np.maximum(cols - 0.5, geo.x_left[n, b]),
                0,
                1,
            )
            rows = image[layout.top[n, b] : layout.bottom[n, b]].sum(axis=0)
            assert sums[n, b] == pytest.approx(rows @ weight, rel=1e-12)
    # The two stacked pixels share the rows between them.
    assert np.array_equal(layout.bottom[0], layout.top[1])


def test_deblur_solves_each_pixels_regularised_problem(calibrated_sim):
    _, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    deblur = SpectralDeblur.from_bundle(bundle, full_scale=65535.0)
    model = deblur.model
    point = 2 * model.grid_u.size + 4  # a field point: its own operators
    row, col = model.grid_v[2], model.grid_u[4]
    a = model.spill[point]
    n = a.shape[0]
    penalty = SmoothnessPrior(PIXEL_GUARD_WEIGHT).penalty(model.sigma_px, model.guard)[point]
    gram = a.T @ a
    spectrum = 1000.0 * (1.2 + np.sin(np.linspace(0, 3, n)))
    values = (a @ spectrum)[None] * np.array([[1.0], [0.01]])  # bright and dark pixels
    unmixed = deblur.apply(values, np.array([row, row]), np.array([col, col]))
    for y, x, alpha in zip(values, unmixed, deblur.weights(values), strict=True):
        normal = gram + alpha * (np.trace(gram) / n) * (penalty.T @ penalty)
        assert x == pytest.approx(np.linalg.solve(normal, a.T @ y), rel=1e-6, abs=1e-9)
    # Dark pixels are smoothed more than bright ones.
    assert deblur.weights(values)[1] > deblur.weights(values)[0]


def test_deblur_in_single_precision_follows_double(calibrated_sim):
    _, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    deblur = SpectralDeblur.from_bundle(bundle, full_scale=65535.0)
    h, w = bundle.slm_shape
    rng = np.random.default_rng(6)
    rows, cols = rng.integers(0, h, 400), rng.integers(0, w, 400)
    geo = streak_geometry(bundle, rows, cols)
    a = box_overlap(geo.x_left, geo.x_right, geo.sigma)
    spectra = rng.uniform(0.5, 1.5, (400, 1)) * (1.2 + np.sin(np.linspace(0, 3, a.shape[-1])))
    values = np.einsum("nij,nj->ni", a, 10.0 ** rng.uniform(0, 4, (400, 1)) * spectra)
    double = deblur.apply(values, rows, cols)
    single = deblur.apply(values.astype(np.float32), rows, cols)
    assert single.dtype == np.float32 and double.dtype == np.float64
    # On the band's bins, which are all any caller keeps (the outer guards, barely held
    # by the snapshots' weak ridge, differ by up to about 1e-6 of the spectrum).
    band = slice(deblur.guard, -deblur.guard)
    error = np.linalg.norm((single - double)[:, band], axis=1) / np.linalg.norm(
        double[:, band], axis=1
    )
    assert error.max() < 1e-6


def test_reached_rows_hold_every_streak(calibrated_sim):
    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    top, bottom = reached_rows(bundle, rig.description.spectral_camera.height)
    h, w = bundle.slm_shape
    rng = np.random.default_rng(3)
    geo = streak_geometry(bundle, rng.integers(0, h, 500), rng.integers(0, w, 500))
    assert top <= geo.y.min() - 3 * geo.sigma.max()
    assert geo.y.max() + 3 * geo.sigma.max() < bottom
    shifted = geo.shifted(top).select(np.arange(10))
    assert np.allclose(shifted.y, geo.y[:10] - top)


def test_a_geometry_with_nan_is_refused():
    geo = StreakGeometry(
        rows=np.array([0]),
        cols=np.array([0]),
        x_left=np.array([[2.0, np.nan]]),
        x_right=np.array([[4.0, 5.0]]),
        y=np.array([[3.0, 3.0]]),
        sigma=np.array([0.3, 0.3]),
        guard=0,
    )
    with pytest.raises(ValueError, match=r"spectrum extraction.*not finite.*bundle verify"):
        cell_layout(geo, (8, 8))


def test_a_spot_narrower_than_a_row_keeps_its_centres_row():
    """Two stacked pixels whose spots are far narrower than a camera row (a field blur
    extrapolated past its lasers gave the singlet's blue end 0.04 px): every cell holds
    the row of its centre, and the unmixing gives the light back, not 0 / 0."""
    centres = np.array([[18.0, 18.3, 17.7], [24.0, 24.3, 23.7]])
    geo = StreakGeometry(
        rows=np.array([0, 7]),
        cols=np.array([3, 3]),
        x_left=np.full((2, 3), 10.0),
        x_right=np.full((2, 3), 11.0),
        y=centres,
        sigma=np.full(3, 0.04),
        guard=0,
    )
    layout = cell_layout(geo, (40, 30))
    assert np.all(layout.lo < centres) and np.all(centres < layout.hi)
    light = np.array([[5.0, 7.0, 11.0], [13.0, 17.0, 19.0]])
    # The whole spot in its centre's row; a cell sums the rows between its bounds.
    rows = np.floor(centres + 0.5)
    sums = light * ((layout.lo < rows) & (rows < layout.hi))
    amplitudes = unmix_rows(sums, layout, geo)
    assert np.isfinite(amplitudes).all()
    np.testing.assert_allclose(amplitudes, light, rtol=1e-6)
