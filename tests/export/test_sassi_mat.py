"""The sassi-mat calibration export, read back with scipy and checked against the bundle."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import loadmat

from sassi_bench.bundle import load
from sassi_bench.bundle.integrity import sha256_file
from sassi_bench.commands import main
from sassi_bench.errors import ProcedureError
from sassi_bench.export.sassi_mat import export_sassi_mat, suggested_ksizes


def test_shapes_dtypes_and_bands(exported, loaded, sim_bundle):
    bundle, _ = sim_bundle
    calib, reverse = loaded
    hc, wc = 512, 800  # procedures/rigs/sim.yaml
    hl, wl = bundle.slm_shape
    t = bundle.wavelengths.size
    for name in ("calibstack_row", "calibstack_col"):
        assert calib[name].shape == (hc, wc, t)
        assert calib[name].dtype == np.float32  # grid_sample needs the cube's float32
    for name in ("Xl", "Yl"):
        assert reverse[name].shape == (hl, wl, t)
        assert reverse[name].dtype == np.float32
    np.testing.assert_array_equal(calib["wavelengths"].ravel(), bundle.wavelengths)
    np.testing.assert_array_equal(reverse["wavelengths"].ravel(), bundle.wavelengths)
    sigma = bundle.blur_width(bundle.wavelengths)
    np.testing.assert_allclose(calib["blur_sigma_px"].ravel(), sigma)
    np.testing.assert_array_equal(calib["ksizes"].ravel(), suggested_ksizes(sigma))
    sha = sha256_file(bundle.path / "manifest.json")
    for mat in (calib, reverse):
        assert str(mat["bundle_version"][0]) == bundle.version
        assert str(mat["bundle_manifest_sha256"][0]) == sha


def test_reverse_lookup_is_the_bundle_map_one_based(loaded, sim_bundle, rng):
    """Xl - 1 is the camera row and Yl - 1 the camera column of slm_to_camera."""
    bundle, _ = sim_bundle
    _, reverse = loaded
    hl, wl = bundle.slm_shape
    lam = bundle.wavelengths
    rows, cols = rng.integers(0, hl, 500), rng.integers(0, wl, 500)
    bands = rng.integers(0, lam.size, 500)
    x, y = bundle.slm_to_camera(cols, rows, lam[bands])
    # float32 holds these coordinates (< 1024) to 6e-5 px.
    np.testing.assert_allclose(reverse["Xl"][rows, cols, bands] - 1.0, y, atol=1e-4, rtol=0)
    np.testing.assert_allclose(reverse["Yl"][rows, cols, bands] - 1.0, x, atol=1e-4, rtol=0)


def test_calibstack_inverts_the_map_where_a_streak_lands(loaded, sim_bundle, rng):
    bundle, _ = sim_bundle
    calib, _ = loaded
    hl, wl = bundle.slm_shape
    lam = bundle.wavelengths
    rows, cols = rng.integers(0, hl, 2000), rng.integers(0, wl, 2000)
    bands = rng.integers(0, lam.size, 2000)
    x, y = bundle.slm_to_camera(cols, rows, lam[bands])
    px, py = np.rint(x).astype(int), np.rint(y).astype(int)
    on_camera = (px >= 0) & (px < 800) & (py >= 0) & (py < 512)
    assert on_camera.mean() > 0.99
    r, c, px, py, b = rows[on_camera], cols[on_camera], px[on_camera], py[on_camera], bands
    b = b[on_camera]
    back_row = calib["calibstack_row"][py, px, b] - 1.0
    back_col = calib["calibstack_col"][py, px, b] - 1.0
    # The camera pixel nearest to where SLM pixel (r, c) lands sees that SLM pixel: the
    # relay magnifies 1.08x, so rounding to a camera pixel moves at most 0.47 SLM px.
    assert np.abs(back_row - r).max() <= 0.5
    assert np.abs(back_col - c).max() <= 0.5
    assert np.array_equal(np.rint(back_row), r) and np.array_equal(np.rint(back_col), c)
    # And exactly: the stored position maps onto that camera pixel's centre.
    fx, fy = bundle.slm_to_camera(back_col.astype(float), back_row.astype(float), lam[b])
    assert np.abs(fx - px).max() < 0.005 and np.abs(fy - py).max() < 0.005


def test_unreached_camera_pixels_hold_zero(loaded, exported, sim_bundle):
    """Camera pixels whose centre sees no SLM pixel are 0 in both arrays (never NaN), and
    every reached pixel maps inside the SLM."""
    bundle, _ = sim_bundle
    calib, _ = loaded
    hl, wl = bundle.slm_shape
    row, col = calib["calibstack_row"], calib["calibstack_col"]
    assert np.isfinite(row).all() and np.isfinite(col).all()
    unreached = row == 0
    np.testing.assert_array_equal(unreached, col == 0)
    np.testing.assert_allclose(unreached.mean(axis=(0, 1)), exported.unreached_fraction)
    assert 0.05 < unreached.mean() < 0.6  # the SLM's image covers part of the camera
    assert row[~unreached].min() >= 0.5 and row[~unreached].max() <= hl + 0.5
    assert col[~unreached].min() >= 0.5 and col[~unreached].max() <= wl + 0.5
    # The SLM's corners at the bluest band: just inside reached, just outside not.
    x, y = bundle.slm_to_camera(np.array([0.0, wl - 1.0]), np.array([0.0, hl - 1.0]), 401.3)
    top_left = int(np.ceil(y[0])) + 1, int(np.ceil(x[0])) + 1
    assert not unreached[top_left[0], top_left[1], 0]
    assert unreached[int(np.floor(y[0])) - 2, int(np.floor(x[0])) - 2, 0]


def test_readme_names_the_bundle_and_the_contract(exported, sim_bundle):
    bundle, _ = sim_bundle
    text = (exported.folder / "README.txt").read_text()
    assert f"{bundle.rig_name}/{bundle.version}" in text
    assert sha256_file(bundle.path / "manifest.json") in text
    for needle in ("1-based", "Xl holds rows and Yl columns", "0 (both arrays)", "float32"):
        assert needle in text


def test_synthetic_bundle_magnified_relay(tmp_path, synthetic):
    """A relay of 2.8 camera px per SLM px (many camera pixels per SLM pixel)."""
    bundle = load(synthetic.publish_synthetic(tmp_path / "data"))
    lam = np.array([450.0, 550.0, 650.0])
    done = export_sassi_mat(
        bundle, tmp_path / "out", wavelengths=lam, camera_shape=(2048, 2048), progress=False
    )
    calib = loadmat(done.folder / "calibstack.mat")
    rng = np.random.default_rng(3)
    py, px = rng.integers(0, 2048, 3000), rng.integers(0, 2048, 3000)
    b = rng.integers(0, 3, 3000)
    row = calib["calibstack_row"][py, px, b].astype(float) - 1.0
    col = calib["calibstack_col"][py, px, b].astype(float) - 1.0
    reached = calib["calibstack_row"][py, px, b] != 0
    assert 0.3 < reached.mean() < 0.7
    fx, fy = bundle.slm_to_camera(col[reached], row[reached], lam[b[reached]])
    assert np.abs(fx - px[reached]).max() < 0.005
    assert np.abs(fy - py[reached]).max() < 0.005


def test_refuses_bands_outside_the_bundle_and_existing_files(exported, sim_bundle, tmp_path):
    bundle, _ = sim_bundle
    with pytest.raises(ProcedureError, match="outside the bundle's calibrated range"):
        export_sassi_mat(bundle, tmp_path, wavelengths=[380.0, 500.0], progress=False)
    with pytest.raises(ProcedureError, match="not increasing"):
        export_sassi_mat(bundle, tmp_path, wavelengths=[500.0, 450.0], progress=False)
    with pytest.raises(ProcedureError, match="already exist"):
        export_sassi_mat(bundle, exported.folder, progress=False)


def test_cli_bundle_export_sassi_mat(capsys, sim_bundle, tmp_path):
    _, root = sim_bundle
    out = tmp_path / "for_sassi"
    argv = ["bundle", "export", "latest", "--rig", "sim", "--data", str(root)]
    code = main([*argv, "--format", "sassi-mat", "--out", str(out), "--wavelengths",
                 "450,532,635", "--quiet"])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    assert "3 bands 450.0-635.0 nm" in printed and "README.txt" in printed
    calib = loadmat(out / "calibstack.mat")
    assert calib["calibstack_row"].shape == (512, 800, 3)
    np.testing.assert_array_equal(calib["wavelengths"].ravel(), [450.0, 532.0, 635.0])
    # The zip export stays the default and still needs --zip.
    assert main(argv) == 2
    assert "--zip" in capsys.readouterr().err
    assert main([*argv, "--format", "sassi-mat"]) == 2
    assert "--out" in capsys.readouterr().err
