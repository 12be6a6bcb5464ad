"""The sassi-mat calibration export, read back with scipy and checked against the bundle."""

from __future__ import annotations

import shutil
import subprocess

import numpy as np
import pytest
from scipy.io import loadmat

from sassi_bench.bundle import load
from sassi_bench.bundle.integrity import sha256_file
from sassi_bench.commands import main
from sassi_bench.errors import ProcedureError
from sassi_bench.export.sassi_mat import export_sassi_mat, preset_wavelengths, suggested_ksizes


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
        assert mat["position_quantum_px"].item() == 1 / 64
    # The row window depends on the capture: it is in adaptive_cassi.mat, not here.
    assert "vsize" not in calib and "row_window_share" not in calib


def test_reverse_lookup_is_the_bundle_map_one_based(loaded, sim_bundle, rng):
    """Xl - 1 is the camera row and Yl - 1 the camera column of slm_to_camera (rounded
    to 1/64 px by default)."""
    bundle, _ = sim_bundle
    _, reverse = loaded
    hl, wl = bundle.slm_shape
    lam = bundle.wavelengths
    rows, cols = rng.integers(0, hl, 500), rng.integers(0, wl, 500)
    bands = rng.integers(0, lam.size, 500)
    x, y = bundle.slm_to_camera(cols, rows, lam[bands])
    # Rounded to 1/64 px: at most 1/128 px off (float32 adds at most 6e-5 px).
    np.testing.assert_allclose(reverse["Xl"][rows, cols, bands] - 1.0, y, atol=0.0079, rtol=0)
    np.testing.assert_allclose(reverse["Yl"][rows, cols, bands] - 1.0, x, atol=0.0079, rtol=0)


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
    # And: the stored position maps onto that camera pixel's centre (to the 1/128 SLM px
    # of the rounding, times the relay's 1.08).
    fx, fy = bundle.slm_to_camera(back_col.astype(float), back_row.astype(float), lam[b])
    assert np.abs(fx - px).max() < 0.014 and np.abs(fy - py).max() < 0.014


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


def test_readme_names_the_bundle_and_the_calls(exported, sim_bundle):
    """README.txt: the bundle, the upstream commit, and the calls of cassi.py's __main__
    with ksizes and vsize read from the files (tests/export/test_sassi_upstream.py runs
    that block); no step of ours between their functions."""
    from sassi_bench.export.sassi_readme import CALLS

    bundle, _ = sim_bundle
    text = (exported.folder / "README.txt").read_text()
    assert f"{bundle.rig_name}/{bundle.version}" in text
    assert sha256_file(bundle.path / "manifest.json") in text
    assert "commit 77d27e3" in text and CALLS in text
    for needle in (
        "cassi.get_cassi_cube(cassi_img, mask, Xl, Yl, calibstack_row,",
        "ksizes = calibdata['ksizes'].ravel()",
        "vsize = int(data['vsize'].item())",
        "cassi.slic_update(imrgb,",
        "cassi.recon_superpixel(cube[h1:h2, w1:w2], mask[h1:h2, w1:w2], L,",
        "rounded to 0.015625 px",
    ):
        assert needle in text, needle
    assert "row_window_share" not in text


def test_synthetic_bundle_magnified_relay(tmp_path, synthetic):
    """A relay of 2.8 camera px per SLM px (many camera pixels per SLM pixel)."""
    bundle = load(synthetic.publish_synthetic(tmp_path / "data"))
    lam = np.array([450.0, 550.0, 650.0])
    done = export_sassi_mat(
        bundle, tmp_path / "out", wavelengths=lam, camera_shape=(2048, 2048),
        position_quantum_px=0, progress=False,
    )  # fmt: skip
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


@pytest.fixture(scope="module")
def exact_and_rounded(sim_bundle, tmp_path_factory):
    """Two bands exported with exact positions and rounded to 1/64 px."""
    bundle, _ = sim_bundle
    out = tmp_path_factory.mktemp("rounding")
    bands = [450.0, 650.0]
    exact = export_sassi_mat(
        bundle, out / "exact", wavelengths=bands, position_quantum_px=0, progress=False
    )
    rounded = export_sassi_mat(bundle, out / "rounded", wavelengths=bands, progress=False)
    return exact, rounded


def test_rounded_positions_are_within_half_a_quantum_and_much_smaller(exact_and_rounded):
    exact, rounded = exact_and_rounded
    assert exact.position_quantum_px == 0 and rounded.position_quantum_px == 1 / 64
    for name, keys in (("calibstack.mat", ("calibstack_row", "calibstack_col")),
                       ("reverse_lookup.mat", ("Xl", "Yl"))):  # fmt: skip
        a, b = loadmat(exact.folder / name), loadmat(rounded.folder / name)
        assert b["position_quantum_px"].item() == 1 / 64 and a["position_quantum_px"] == 0
        for key in keys:
            assert b[key].dtype == np.float32
            np.testing.assert_array_equal(b[key] * 64, np.rint(b[key] * 64))
            assert np.abs(b[key].astype(np.float64) - a[key]).max() <= 1 / 128
            assert np.abs(a[key] * 64 - np.rint(a[key] * 64)).max() > 0.4  # exact: not rounded
        # zlib squeezes the rounded tables 3.5-4.5x (the exact ones' low bits are noise).
        assert (rounded.folder / name).stat().st_size < 0.35 * (exact.folder / name).stat().st_size


@pytest.mark.skipif(shutil.which("octave-cli") is None, reason="Octave is not installed")
def test_octave_loads_the_files_as_matlab_would(exact_and_rounded):
    """MATLAB's own format (v7, compressed): Octave's load reads classes and shapes."""
    _, rounded = exact_and_rounded
    script = (
        f"c = load('{rounded.folder / 'calibstack.mat'}'); "
        f"r = load('{rounded.folder / 'reverse_lookup.mat'}'); "
        "printf('%s %s %s %d %s\\n', class(c.calibstack_row), mat2str(size(c.calibstack_row)), "
        "class(c.ksizes), numel(c.ksizes), mat2str(size(r.Xl))); "
        "printf('%.6f\\n', r.Xl(1, 1, 1));"
    )
    done = subprocess.run(
        ["octave-cli", "--no-gui", "--quiet", "--eval", script],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    first, value = done.stdout.strip().splitlines()[-2:]
    assert first == "single [512 800 2] double 2 [400 640 2]"
    xl = loadmat(rounded.folder / "reverse_lookup.mat")["Xl"][0, 0, 0]
    assert float(value) == pytest.approx(float(xl), abs=1e-6)


def test_paper_preset_takes_every_10_nm_inside_the_bundle(sim_bundle):
    bundle, _ = sim_bundle
    bands = preset_wavelengths("paper", bundle)  # the bins span 400.3-701.6 nm
    np.testing.assert_array_equal(bands, np.arange(410.0, 701.0, 10.0))
    np.testing.assert_array_equal(preset_wavelengths("10nm", bundle), bands)
    np.testing.assert_array_equal(preset_wavelengths("bins", bundle), bundle.wavelengths)
    with pytest.raises(ProcedureError, match="no wavelength preset 'blue'"):
        preset_wavelengths("blue", bundle)


def test_refuses_bands_outside_the_bundle_and_existing_files(exported, sim_bundle, tmp_path):
    bundle, _ = sim_bundle
    with pytest.raises(ProcedureError, match="not 0 or a power of two"):
        export_sassi_mat(bundle, tmp_path, position_quantum_px=0.3, progress=False)
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
                 "450,532,635", "--position-quantum", "1/256",
                 "--quiet"])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0
    assert "3 bands 450.0-635.0 nm" in printed and "README.txt" in printed
    assert "rounded to 0.00390625 px" in printed
    calib = loadmat(out / "calibstack.mat")
    assert calib["calibstack_row"].shape == (512, 800, 3)
    assert calib["position_quantum_px"].item() == 1 / 256
    np.testing.assert_array_equal(calib["wavelengths"].ravel(), [450.0, 532.0, 635.0])
    # The zip export stays the default and still needs --zip.
    assert main(argv) == 2
    assert "--zip" in capsys.readouterr().err
    assert main([*argv, "--format", "sassi-mat"]) == 2
    assert "--out" in capsys.readouterr().err
    assert main([*argv, "--zip", str(tmp_path / "b.zip"), "--wavelengths", "paper"]) == 2
    assert "--wavelengths paper is read only with --format sassi-mat" in capsys.readouterr().err
