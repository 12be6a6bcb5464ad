"""Streak geometry: bins placed by the bundle's dispersion model."""

import numpy as np

from sassi_bench.bundle import load
from sassi_bench.spectra.geometry import bin_wavelengths, clipped_blur, streak_geometry


def test_streak_geometry_follows_the_bundles_map(calibrated_sim):
    _, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    h, w = bundle.slm_shape
    rng = np.random.default_rng(4)
    rows, cols = rng.integers(0, h, 300), rng.integers(0, w, 300)
    geo = streak_geometry(bundle, rows, cols, guard=3)
    # The bundle's public map, evaluated independently at the edges and the centres.
    x_edges, _ = bundle.slm_to_camera(cols[:, None], rows[:, None], bundle.bin_edges)
    _, y_centres = bundle.slm_to_camera(cols[:, None], rows[:, None], bundle.wavelengths)
    core = geo.core
    assert np.allclose(geo.x_left[:, core], np.minimum(x_edges[:, :-1], x_edges[:, 1:]))
    assert np.allclose(geo.x_right[:, core], np.maximum(x_edges[:, :-1], x_edges[:, 1:]))
    assert np.allclose(geo.y[:, core], y_centres)
    # Guard bins: one pixel wide, adjoining the band's ends, on the end bins' rows.
    first, last = core.start, core.stop - 1
    assert np.allclose(geo.x_right[:, :first] - geo.x_left[:, :first], 1.0)
    assert np.allclose(geo.x_right[:, first - 1], geo.x_left[:, first])
    assert np.allclose(geo.x_left[:, last + 1], geo.x_right[:, last])
    assert np.allclose(np.diff(geo.x_left[:, last + 1 :], axis=1), 1.0)
    assert np.allclose(geo.y[:, :first], geo.y[:, [first]])
    assert np.allclose(geo.y[:, last + 1 :], geo.y[:, [last]])


def test_streak_geometry_of_no_pixels(calibrated_sim):
    _, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    geo = streak_geometry(bundle, [], [], guard=2)
    assert geo.y.shape == geo.x_left.shape == (0, bundle.wavelengths.size + 4)


def test_guard_bins_keep_the_band_ends_blur_across_the_streak(calibrated_sim):
    _, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    geo = streak_geometry(bundle, [200, 10], [320, 600])
    band = np.asarray(bundle.blur_width(bundle.wavelengths))
    # Across the streak (the row unmixing's blur) the guards hold the band end's tail...
    assert geo.sigma.shape == geo.y.shape  # per pixel and bin
    assert np.all(geo.sigma[:, : geo.guard] == band[0])
    assert np.all(geo.sigma[:, -geo.guard :] == band[-1])
    assert np.array_equal(geo.sigma[:, geo.core], np.broadcast_to(band, (2, band.size)))
    # ...along it (the deblur's unknowns) each guard takes the blur at its own wavelength.
    lam = bin_wavelengths(bundle, geo)
    assert np.array_equal(lam[:, geo.core], np.broadcast_to(bundle.wavelengths, (2, band.size)))
    assert np.all(np.diff(lam[:, geo.core.stop - 1 :], axis=1) > 0)
    along = clipped_blur(bundle, geo.rows[:, None], geo.cols[:, None], lam)
    assert np.all(along[:, -1] > 1.2 * geo.sigma[:, -1])
    assert np.allclose(along[:, geo.core], band)
