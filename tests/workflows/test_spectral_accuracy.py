"""Spectral calibration scored against the virtual bench's ground truth.

Each rig is calibrated once per test module (about a minute each): the default rig, an
odd one (SLM rotated 2 degrees, a dense flint prism, three times the read noise) and one
with another set of four laser lines (405, 488, 561, 640 nm), calibrated with the shipped
procedure, which sweeps the rig's own lasers.
The default rig already uses N-BK7 (it reproduces the paper's 2-10 nm/px bins), so the
odd rig swaps in F2, whose stronger dispersion makes the field dependence harsher.
"""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.bundle import load
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.spectral import run_spectral_calibration

# Each rig's figures against the truth are held to about twice what is measured (the
# measured value beside each bound; the targets are far looser): the wavelength
# map's error over the band (RMS and worst, nm; rows, camera px RMS), and the blur's
# (the spot widths at the lasers and the model's prediction of them, the model between
# and beyond the lasers).
BOUNDS = {
    "sim": {
        "map_rms_nm": 0.022,  # measured 0.0109
        "map_max_nm": 0.125,  # 0.0625
        "rows_rms_px": 0.026,  # 0.0129
        "spot_rel": 0.0042,  # 0.0021
        "predicted_px": 0.0025,  # 0.00126 (blur pinholes 26 SLM px apart, from the optics)
        "band_rel": 0.003,  # 0.00146 (0.00025 with blur pinholes 40 SLM px apart)
    },
    "sim-odd": {
        "map_rms_nm": 0.046,  # measured 0.0230
        "map_max_nm": 0.17,  # 0.0834
        "rows_rms_px": 0.036,  # 0.0178
        "spot_rel": 0.0066,  # 0.0033
        "predicted_px": 0.0036,  # 0.0018
        "band_rel": 0.0038,  # 0.0019
    },
    "sim-four-lines": {
        "map_rms_nm": 0.023,  # measured 0.0115
        "map_max_nm": 0.19,  # 0.0935
        "rows_rms_px": 0.033,  # 0.0165
        "spot_rel": 0.0017,  # 0.00085
        "predicted_px": 0.0011,  # 0.00053
        "band_rel": 0.0022,  # 0.0011
    },
}


def _odd_rig():
    data = load_rig_description("sim").to_dict()
    data["name"] = "sim-odd"
    data["relay"]["rotation_deg"] = 2.0
    data["relay"]["scale"] = 1.04
    data["relay"]["offset_px"] = [28.0, 3.0]
    data["prism"]["glass"] = "F2"
    data["spectral_camera"]["read_noise_e"] = 15.0
    return open_rig(rig_description_from_dict(data))


def _four_line_rig():
    data = load_rig_description("sim").to_dict()
    data["name"] = "sim-four-lines"
    data["lasers_nm"] = [405, 488, 561, 640]
    return open_rig(rig_description_from_dict(data))


@pytest.fixture(scope="module", params=["default", "odd", "four-lines"])
def calibrated(request, tmp_path_factory):
    if request.param == "default":
        return request.getfixturevalue("calibrated_sim")
    rig = _odd_rig() if request.param == "odd" else _four_line_rig()
    data = tmp_path_factory.mktemp(f"data-{request.param}")
    result = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=data, progress=False, session_id="acc"
    )
    return rig, result, data


def test_every_quality_check_passes_and_a_bundle_is_published(calibrated):
    rig, result, data = calibrated
    assert result.passed, [c for c in result.checks if not c.passed]
    bundle = load(rig=rig.description.name, data=data)
    assert bundle.passed
    assert 60 <= bundle.wavelengths.size <= 76
    assert {"residual_maps.png", "dispersion.png", "blur.png"} <= set(
        p.name for p in (bundle.path / "report").iterdir()
    )
    # Every shipped-sim-based rig has wavelength lamps: their frames are a third input.
    assert [i["id"] for i in bundle.manifest["inputs"]] == ["acc-grey", "acc-sweep", "acc-lamps"]
    assert [d.wavelength_nm for d in result.lasers] == list(rig.description.lasers_nm)
    assert set(result.dispersion.leave_one_out) == set(rig.description.lasers_nm)


def test_correspondences_land_where_truth_says(calibrated):
    # The four-line rig's 640 nm sweep once kept a few dim pixels with a wrong Gray word
    # (one 316 px off, RMS 0.59 px): the decoder now refuses pixels below 5 % of the
    # bright level as dark and flags coordinates that disagree with their neighbours.
    rig, result, _ = calibrated
    t = truth(rig)
    for laser in result.lasers:
        x, y = t.slm_to_camera(laser.slm_u, laser.slm_v, laser.wavelength_nm)
        error = np.hypot(x - laser.camera_x, y - laser.camera_y)
        # Issue target 0.1 px; measured 0.022-0.035 px on every rig, so hold it to 0.06 px.
        assert np.sqrt(np.mean(error**2)) <= 0.06, laser.wavelength_nm
        assert laser.valid_fraction > 0.85


def test_wavelength_map_matches_truth_over_the_band(calibrated):
    rig, result, _ = calibrated
    t = truth(rig)
    h, w = rig.slm.shape
    u, v = np.meshgrid(np.linspace(0, w - 1, 17), np.linspace(0, h - 1, 11))
    lam = np.linspace(400, 700, 61)
    xm, ym = result.dispersion.model.evaluate(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
    xt, yt = t.slm_to_camera(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
    error_nm = (xm - xt) / np.gradient(xt, lam, axis=1)
    bounds = BOUNDS[rig.description.name]  # the target: 0.5 nm RMS
    assert np.sqrt(np.mean(error_nm**2)) <= bounds["map_rms_nm"]
    assert np.abs(error_nm).max() <= bounds["map_max_nm"]
    assert np.sqrt(np.mean((ym - yt) ** 2)) <= bounds["rows_rms_px"]


def test_blur_width_matches_truth(calibrated):
    rig, result, _ = calibrated
    t = truth(rig)
    lasers = result.blur.wavelengths_nm
    # Issue target 0.2 px: the measured spot widths, and what the model predicts a camera
    # measures at the lasers.
    spot = t.line_spread_sigma_px(lasers)
    bounds = BOUNDS[rig.description.name]
    assert result.blur.measured_sigma_px == pytest.approx(spot, rel=bounds["spot_rel"])
    predicted = result.blur.measured_sigma_px + result.blur.residual_px
    assert predicted == pytest.approx(spot, abs=bounds["predicted_px"])
    # Between and beyond the lasers, relative to the spot before the camera pixel (what the
    # bundle's blur is: its users integrate it over camera pixels): the PSF's quadratic with
    # the SLM pixel's image in quadrature (the paper's quadratic through the spot widths was
    # 4.5 % off the spot at 580-600 nm on the chain's bundle).
    band = np.arange(450.0, 691.0, 10.0)
    error = result.blur.model.sigma(band) / np.sqrt(t.line_spread_sigma_px(band) ** 2 - 1 / 12) - 1
    assert result.blur.model.kind == "psf_quadratic"
    assert np.abs(error).max() <= bounds["band_rel"]


def test_the_papers_line_sweep_cross_checks_the_structured_sweep(tmp_path):
    rig = open_rig("sim")
    proc = load_procedure("spectral_calibration")
    proc["sweep"]["mode"] = "lines"
    result = run_spectral_calibration(
        rig, proc, data=tmp_path, progress=False, publish_bundle=False
    )
    assert result.passed, [c for c in result.checks if not c.passed]
    t = truth(rig)
    for laser in result.lasers:
        x, y = t.slm_to_camera(laser.slm_u, laser.slm_v, laser.wavelength_nm)
        error = np.hypot(x - laser.camera_x, y - laser.camera_y)
        assert np.sqrt(np.mean(error**2)) <= 0.0085  # measured 0.0017-0.0042 px
        # Line centres scatter about their fit: measured 0.029-0.072 px.
        assert 0.01 < laser.residual_rms_px < 0.15
    assert result.dispersion.leave_one_out_rms_nm <= 0.05  # measured 0.026
    frames = len(result.sessions[0].plan)  # the sweep (the lamp frames follow it)
    # Multi-line shift: 2 x 64 / 8 = 16 line frames per laser, plus 3 references and 3 blur.
    assert frames == 5 * (16 + 3 + 3)
