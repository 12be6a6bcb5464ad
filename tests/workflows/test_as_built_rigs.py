"""Procedures on benches built otherwise than described, scored against the truth.

The rig with every as-built deviation (``tests/rigs/as-built-all.yaml``: the 635 nm laser
at 637.8 nm, another glass melt and apex, an 80 K hotter lamp, another LED, another
guide sensor, another SLM gamma) is swept once; the sweeps are analysed with the shipped
procedure (which must fail, naming the laser) and with
``fit.estimate_laser_wavelengths`` (which must meet its tolerances against the truth).
"""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.bundle import load
from sassi_bench.calibrate.guide_registration import field_discrepancy_px, register_guide
from sassi_bench.calibrate.guide_render import render_rgb, rendering_sensitivities
from sassi_bench.calibrate.radiometry import source_photons_in_bins
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.spectral import analyse_spectral_sweeps, laser_line_notes
from sassi_bench.reduce.spectral_bundle import publish_spectral
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.guide import capture_guide
from sassi_bench.workflows.scan import run_response
from sassi_bench.workflows.spectral import capture_spectral_sweeps

RIGS = "tests/rigs/"


def _rms(error) -> float:
    return float(np.sqrt(np.mean(np.square(error))))


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """The all-deviations rig's spectral sweeps, captured once."""
    rig = open_rig(RIGS + "as-built-all.yaml")
    data = tmp_path_factory.mktemp("as-built")
    proc = load_procedure("spectral_calibration")
    sweeps = capture_spectral_sweeps(rig, proc, session_id="acc", data=data, progress=False)
    return rig, sweeps, data


def _analysed(swept, estimate: bool):
    rig, sweeps, _ = swept
    proc = load_procedure("spectral_calibration")
    proc["fit"]["estimate_laser_wavelengths"] = estimate
    return analyse_spectral_sweeps(sweeps, proc, rig.description)


@pytest.fixture(scope="module")
def estimated(swept):
    """The sweeps analysed with fit.estimate_laser_wavelengths, and its bundle."""
    result = _analysed(swept, estimate=True)
    return result, publish_spectral(result, data=swept[2])


def test_a_laser_off_its_label_fails_a_check_that_names_it(swept):
    result = _analysed(swept, estimate=False)
    failed = {c.name for c in result.checks if not c.passed}
    assert "laser_line_635nm" in failed
    assert not {c for c in failed if c.startswith("laser_line_") and c != "laser_line_635nm"}
    # Only the line and what it spoils fail (leave-one-out, and the map's stated 1-sigma,
    # which the mislabelled line's scatter inflates): the glass, apex and SLM gamma are
    # absorbed.
    spoiled = {"leave_one_out_rms_nm", "leave_one_out_max_px", "map_sigma_px", "map_sigma_nm"}
    assert failed <= {"laser_line_635nm"} | spoiled
    notes = laser_line_notes(result)
    (note,) = [n for n in notes if n.startswith("laser 635 nm")]
    assert note.startswith("laser 635 nm: the 450, 520, 532, 670 nm lines put it at 637.8")
    # Judged without 635 nm, the end lines are extrapolations from 520-532 nm: passed,
    # with a note of how loosely (allowed 6.9 and 24.5 nm on the true maps).
    assert {n.split(":")[0] for n in notes if "checked only within" in n} <= {
        "laser 450 nm",
        "laser 670 nm",
    }
    assert "estimate_laser_wavelengths" in note
    assert (
        _rms(truth(swept[0]).wavelength_map_error_nm(result.dispersion.model)) > 0.5
    )  # it would be wrong


def test_estimating_the_line_meets_the_tolerances_against_the_truth(swept, estimated):
    rig = swept[0]
    result, path = estimated
    assert result.passed, [c.describe() for c in result.checks if not c.passed]
    t = truth(rig)
    estimate = result.dispersion.wavelengths_nm[635.0]
    # Targets 0.3 nm and 0.5 nm RMS; held to about twice what is measured.
    assert estimate == pytest.approx(t.laser_centre_nm(635), abs=0.001)  # measured 0.00046 nm
    assert _rms(truth(rig).wavelength_map_error_nm(result.dispersion.model)) <= 0.018  # 0.0092
    for laser in result.lasers:
        x, y = t.slm_to_camera(laser.slm_u, laser.slm_v, t.laser_centre_nm(laser.wavelength_nm))
        # Measured 0.022 px (520 nm) to 0.035 px (670 nm).
        assert np.sqrt(np.mean((x - laser.camera_x) ** 2 + (y - laser.camera_y) ** 2)) < 0.06
    # The SLM's grey levels were measured, not taken from the description's gamma.
    assert result.grey_response.gamma == pytest.approx(2.5, abs=1.5e-4)  # measured 7.3e-5 off
    lines = load(path).manifest["quality"]["laser_lines"]
    assert lines["635"]["fitted_nm"] == estimate and lines["635"]["off_label"]
    assert lines["532"]["fitted_nm"] == 532.0


def test_the_response_is_off_by_the_lamp_temperature_within_its_reported_sensitivity(
    swept, estimated, tmp_path
):
    rig = swept[0]
    bundle = load(estimated[1])
    path = run_response(rig, bundle, session_id="response", data=tmp_path, progress=False)
    response = load(path)
    lamp = response.manifest["quality"]["residuals"]["response"]["lamp_temperature_sensitivity"]
    assert lamp["temperature_k"] == 3000.0 and lamp["delta_k"] == 100.0
    t = truth(rig)
    relative = np.asarray(response.response) / t.relative_response(response.bin_edges)
    relative /= np.median(relative)
    wl = response.wavelengths
    core = (wl > 410) & (wl < 640)
    error = np.abs(relative[core] - 1).max()
    # The lamp is 80 K hotter than described: the response is off by more than the 2 %
    # this stage reaches on the sim rig, but within the reported 100 K sensitivity.
    assert 0.02 < error <= lamp["max_relative_change"] + 0.02  # measured 0.057 (up to 0.123)
    # And it is the lamp: assuming the true temperature brings it back within 2 %.
    edges = response.bin_edges
    corrected = relative * source_photons_in_bins(edges, temperature_k=3000.0)
    corrected /= source_photons_in_bins(edges, temperature_k=t.halogen_k)
    corrected /= np.median(corrected)
    assert np.abs(corrected[core] - 1).max() < 0.011  # measured 0.0053


def test_guide_registers_when_its_sensor_is_not_the_described_one(tmp_path):
    """The scene rendered through the described sensor (Nikon) against a guide camera
    that really has other curves (Sigma): the registration absorbs the difference."""
    rig = open_rig(RIGS + "as-built-guide.yaml")
    bench = truth(rig)
    step = 5  # 10 nm samples are plenty for colour
    wl = bench.wavelengths_nm[::step]
    scene = bench.bench.scene_named("natural")
    rows, cols = scene.slm_window(rig.slm.shape)
    cube = np.moveaxis(
        scene.project(np.eye(bench.wavelengths_nm.size)[::step])[:, rows, cols], 0, -1
    )
    led = bench.light_samples("led")
    described, label = rendering_sensitivities(
        rig.description.guide_camera.sensitivities, "auto", wl
    )
    assert label == "camera: Nikon 5100 (NPL)"
    reference = render_rgb(cube * np.interp(wl, led.wavelengths_nm, led.weights), wl,
                           sensitivities=described)  # fmt: skip
    proc = load_procedure("guide_registration")
    guide, valid, _ = capture_guide(rig, proc, session_id="g", data=tmp_path, progress=False)
    # The colours really differ: the channel balance of the two images is not the same.
    balance = [img.reshape(-1, 3).mean(0) / img.reshape(-1, 3).mean() for img in (reference, guide)]
    assert np.abs(balance[0] - balance[1]).max() > 0.1
    reg = register_guide(guide, reference, guide_valid=valid,
                         sift_options={"contrastThreshold": 0.02})  # fmt: skip
    rms, worst = field_discrepancy_px(reg.homography, bench.guide_to_slm, rig.slm.shape)
    # Target 0.3 px; measured 0.072 px RMS, 0.173 px at worst (0.007 px RMS with the
    # described sensor).
    assert rms <= 0.14 and worst <= 0.33
