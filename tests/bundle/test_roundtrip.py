"""Publish then load: the consumer API gives back exactly the synthetic models."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from sassi_bench._shared.canonical_json import canonical_json
from sassi_bench.bundle import BundleError, CalibrationBundle, load
from sassi_bench.bundle.integrity import sha256_bytes
from sassi_bench.bundle.layout import LATEST_LOCK_NAME


def test_layout_on_disk(published: Path, data_root: Path):
    assert published == data_root / "sim" / "v0001"
    assert (data_root / "sim" / "LATEST").read_text() == "v0001\n"
    names = sorted(p.relative_to(published).as_posix() for p in published.rglob("*") if p.is_file())
    assert names == [
        "arrays/bin_centres_nm.npy",
        "arrays/bin_edges_nm.npy",
        "arrays/bin_resolution_nm.npy",
        "arrays/dispersion_x_coeffs.npy",
        "arrays/dispersion_y_coeffs.npy",
        "arrays/guide_to_slm.npy",
        "arrays/laser_residuals_px.npy",
        "arrays/response.npy",
        "manifest.json",
        "manifest.sha256",
        "report/summary.txt",
    ]
    assert not [
        p
        for p in (data_root / "sim").iterdir()
        if p.name.startswith(".") and p.name != LATEST_LOCK_NAME
    ]


def test_manifest_content(published: Path, synthetic):
    manifest = json.loads((published / "manifest.json").read_text())
    assert manifest["schema"] == "sassi-bench/calibration-bundle"
    assert manifest["schema_version"] == "1.1.0"
    assert manifest["version"] == "v0001" and manifest["parent"] is None
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3}Z", manifest["created"])
    assert manifest["rig"] == synthetic.RIG
    assert manifest["rig_hash"] == sha256_bytes(canonical_json(synthetic.RIG))
    assert manifest["software"]["name"] == "sassi-bench"
    assert manifest["passed"] is True and manifest["override"] is False
    assert manifest["procedure"] == synthetic.PROCEDURE
    assert manifest["inputs"][0]["id"] == "laser-sweep-2024-05-01"
    assert {c["name"] for c in manifest["quality"]["checks"]} == {
        "dispersion_rms",
        "homography_rms",
        "macbeth_psnr",
    }
    assert manifest["quality"]["leave_one_out"] == {"max_error_nm": 0.6}
    entry = manifest["arrays"]["dispersion_x_coeffs"]
    assert entry["dtype"] == "<f8" and entry["shape"] == [3, 10]
    assert entry["file"] == "arrays/dispersion_x_coeffs.npy"
    digest = (published / "manifest.sha256").read_text().split()[0]
    assert digest == sha256_bytes((published / "manifest.json").read_bytes())


def test_slm_to_camera_is_the_synthetic_model(published: Path, synthetic):
    bundle = load(published)
    truth = synthetic.make_dispersion()
    u = np.linspace(0, 639, 7)[:, None]
    v = np.linspace(0, 399, 7)[:, None]
    lam = np.linspace(400, 700, 31)[None, :]
    x, y = bundle.slm_to_camera(u, v, lam)
    x_true, y_true = truth.evaluate(u, v, lam)
    assert x.shape == (7, 31) and x.dtype == np.float64
    np.testing.assert_array_equal(x, x_true)
    np.testing.assert_array_equal(y, y_true)


def test_bins_blur_response_round_trip(published: Path, synthetic):
    bundle = load(published)
    models = synthetic.make_models()
    np.testing.assert_array_equal(bundle.wavelengths, models.bins.centres_nm)
    np.testing.assert_array_equal(bundle.bin_edges, models.bins.edges_nm)
    np.testing.assert_array_equal(bundle.bin_resolution_nm, models.bins.resolution_nm)
    assert bundle.wavelengths.shape == (68,) and bundle.bin_edges.shape == (69,)
    np.testing.assert_allclose(bundle.blur_width([405.0, 520.0, 635.0]), [4.0, 1.0, 4.0])
    np.testing.assert_array_equal(bundle.response, models.response)
    assert bundle.offset_model["method"] == "masked-cubic"
    np.testing.assert_array_equal(bundle.guide_to_slm, synthetic.GUIDE_TO_SLM)
    assert bundle.arrays["laser_residuals_px"].shape == (5, 5)


def test_streak_is_monotonic_and_consistent(published: Path):
    bundle = load(published)
    for u, v in [(0, 0), (319.5, 199.5), (639, 399), (100, 300)]:
        s = bundle.streak(u, v)
        assert s.x.shape == s.y.shape == s.window_px.shape == (68,)
        assert np.all(np.diff(s.x) > 0)
        assert np.all(np.diff(s.wavelength_nm) > 0)
        assert np.all(s.x_left <= s.x) and np.all(s.x <= s.x_right)
        np.testing.assert_allclose(s.x_right[:-1], s.x_left[1:])  # bins tile the streak
        x, y = bundle.slm_to_camera(u, v, bundle.wavelengths)
        np.testing.assert_array_equal(s.x, x)
        np.testing.assert_array_equal(s.y, y)
        np.testing.assert_allclose(s.window_px, 2.5 * bundle.blur_width(bundle.wavelengths))
    centre = bundle.streak(319.5, 199.5)
    # Bins were built one camera pixel wide at the field centre.
    widths = centre.x_right - centre.x_left
    np.testing.assert_allclose(widths, widths.mean(), rtol=1e-3)
    assert 0.9 < widths.mean() < 1.1
    with pytest.raises(ValueError):
        centre.x[0] = 0.0
    with pytest.raises(BundleError, match="outside"):
        bundle.streak(640, 0)
    with pytest.raises(BundleError, match="scalars"):
        bundle.streak([1, 2], 0)


def test_warp_guide_to_slm(published: Path, synthetic):
    bundle = load(published)
    rows, cols = 540, 720
    q, p = np.mgrid[0:rows, 0:cols].astype(np.float32)
    guide = np.stack([p, q], axis=-1).astype(np.float32)  # each pixel holds its own (p, q)
    warped = bundle.warp_guide_to_slm(guide)
    assert warped.shape == (400, 640, 2)
    # Where the SLM pixel sees the guide image, it holds H^-1 (u, v).
    v, u = np.mgrid[0:400, 0:640]
    back = np.linalg.solve(
        synthetic.GUIDE_TO_SLM, np.stack([u.ravel(), v.ravel(), np.ones(u.size)])
    )
    expected_p = (back[0] / back[2]).reshape(400, 640)
    expected_q = (back[1] / back[2]).reshape(400, 640)
    inside = (expected_p > 1) & (expected_p < cols - 2) & (expected_q > 1) & (expected_q < rows - 2)
    assert inside.mean() > 0.9
    np.testing.assert_allclose(warped[..., 0][inside], expected_p[inside], atol=0.05)
    np.testing.assert_allclose(warped[..., 1][inside], expected_q[inside], atol=0.05)
    gray = bundle.warp_guide_to_slm(np.full((rows, cols), 7, np.uint8))
    assert gray.shape == (400, 640) and gray.dtype == np.uint8
    with pytest.raises(BundleError, match="image has shape"):
        bundle.warp_guide_to_slm(np.zeros(5))


def test_bundle_is_immutable(published: Path):
    bundle = load(published)
    assert isinstance(bundle, CalibrationBundle)
    for array in (bundle.wavelengths, bundle.bin_edges, bundle.guide_to_slm, bundle.response):
        with pytest.raises(ValueError):
            array[0] = 0
    for array in bundle.arrays.values():
        assert not array.flags.writeable
    with pytest.raises(TypeError):
        bundle.manifest["passed"] = False
    with pytest.raises(AttributeError):
        bundle.manifest["quality"]["checks"].append({})  # tuples, not lists
    with pytest.raises(AttributeError):
        bundle.path = Path("/elsewhere")  # type: ignore[misc]


def test_optional_models_absent(data_root: Path, synthetic):
    models = synthetic.make_models(guide_to_slm=None, offset=None, response=None)
    path = synthetic.publish_synthetic(data_root, models=models)
    bundle = load(path)
    assert bundle.guide_to_slm is None and bundle.offset_model is None and bundle.response is None
    with pytest.raises(BundleError, match=r"no guide -> SLM homography.*Fix:"):
        bundle.warp_guide_to_slm(np.zeros((10, 10), np.uint8))


def test_load_by_rig_version_latest_and_env(data_root: Path, synthetic, monkeypatch):
    first = synthetic.publish_synthetic(data_root)
    second = synthetic.publish_synthetic(data_root)
    assert load(rig="sim", data=data_root).version == "v0002"
    assert load(rig="sim", version="v0001", data=data_root).path == first
    assert load(rig="sim", version=1, data=data_root).version == "v0001"
    assert load(second).parent == "v0001"
    monkeypatch.setenv("SASSI_BENCH_DATA", str(data_root))
    assert load(rig="sim").version == "v0002"
    assert load(first / "manifest.json").version == "v0001"
    with pytest.raises(BundleError, match=r"no version v0009.*published: v0001, v0002"):
        load(rig="sim", version="v0009")
    with pytest.raises(BundleError, match="no calibration bundle is published for rig 'other'"):
        load(rig="other")
    with pytest.raises(BundleError, match="not a plain folder name"):
        load(rig="../sim")
    with pytest.raises(BundleError, match="not a bundle folder"):
        load(data_root / "nothing")


def test_latest_falls_back_to_highest_version(data_root: Path, synthetic):
    synthetic.publish_synthetic(data_root)
    synthetic.publish_synthetic(data_root)
    (data_root / "sim" / "LATEST").unlink()
    assert load(rig="sim", data=data_root).version == "v0002"


def test_rig_description_is_stored_and_hashed_like_the_rig_package(data_root: Path, synthetic):
    from sassi_bench.rig.config import load_rig_description

    rig = load_rig_description("sim")
    path = synthetic.publish_synthetic(data_root, rig=rig)
    bundle = load(path)
    assert bundle.rig_name == rig.name
    assert bundle.manifest["rig_hash"] == rig.sha256()
    assert json.loads((path / "manifest.json").read_text())["rig"] == rig.to_dict()
