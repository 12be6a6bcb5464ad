"""Lamp-anchored wavelengths on a bench whose diode lasers are off their labels.

``tests/rigs/lamps-diodes-off.yaml``: the 450, 520, 635 and 670 nm diodes sit 3.8-5 nm
off their labels (532 nm exact), the HgAr and Ne lamps' lines are 30 % (log-normal) off
their tables' intensities. One calibration, scored against the bench's truth. And a noisy,
low-dispersion bench whose lamps cannot pin its red lasers
(``tests/rigs/lamps-noisy-nbk7.yaml``).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.plan_geometry import planned_spectral
from sassi_bench.bundle import load
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.lamps import captured_lamp_frames
from sassi_bench.reduce.spectral import (
    analyse_spectral_sweeps,
    lamp_measurement,
    laser_line_notes,
    spectral_notes,
)
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.spectral import (
    capture_lamp_frames,
    capture_spectral_sweeps,
    open_lamp_session,
    run_spectral_calibration,
)

RIG = "tests/rigs/lamps-diodes-off.yaml"


@pytest.fixture(scope="module")
def anchored(tmp_path_factory):
    rig = open_rig(RIG)
    data = tmp_path_factory.mktemp("lamps-diodes-off")
    result = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=data, progress=False, session_id="acc"
    )
    return rig, result, load(rig=rig.description.name, data=data)


def test_the_bundle_passes_and_records_every_laser_s_measured_line(anchored):
    rig, result, bundle = anchored
    assert result.passed, [c.describe() for c in result.checks if not c.passed]
    assert bundle.passed
    quality = bundle.manifest["quality"]
    spectral = quality.get("spectral", quality)
    t = truth(rig)
    for label in rig.description.lasers_nm:
        line = spectral["laser_lines"][f"{label:g}"]
        # The diodes are measured; the exact DPSS line is confirmed and held at its label.
        exact = label == 532
        assert line["method"] == ("lamp-confirmed label" if exact else "lamp-anchored"), label
        # Within 0.22 nm of its true line (measured 0.11 nm at worst, 670 nm).
        assert line["fitted_nm"] == pytest.approx(t.laser_centre_nm(label), abs=0.22), label
        if exact:
            assert line["fitted_nm"] == pytest.approx(532.0, abs=0.001)  # held at its label
        # Issue goal: each laser within 0.3 nm of its true line (measured <= 0.088 nm).
        assert line["measured_nm"] == pytest.approx(t.laser_centre_nm(label), abs=0.18), label
        assert 0 < line["sigma_nm"] < 0.5
    assert set(spectral["lamps"]) == {"HgAr", "Ne"}
    checks = {c["name"] for c in spectral["checks"]}
    assert "spectral.lamp_line_rms_fwhm" in checks
    # A lamp's uncertainty about a line is recorded, not graded (a lamp only adds information).
    assert not any(name.startswith("spectral.laser_wavelength_sigma") for name in checks)
    assert "lamp_spectrum.png" in {p.name for p in (bundle.path / "report").iterdir()}
    assert [i["id"] for i in bundle.manifest["inputs"]][-1] == "acc-lamps"


def test_the_wavelength_map_meets_the_goals_against_the_truth(anchored):
    rig, result, bundle = anchored
    t = truth(rig)
    model = bundle.models.dispersion
    error_nm = t.wavelength_map_error_nm(model)
    # Issue goals: <= 0.3 nm RMS and <= 0.1 camera px RMS; held to twice what is measured
    # (0.053 nm, 0.0070 px; the same sweeps with the lasers at their labels: 3.9 nm, 1.6 px).
    assert np.sqrt(np.mean(error_nm**2)) <= 0.1
    h, w = rig.slm.shape
    u, v = np.meshgrid(np.linspace(0, w - 1, 17), np.linspace(0, h - 1, 11))
    lam = np.linspace(400, 700, 61)
    xm, _ = model.evaluate(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
    xt, _ = t.slm_to_camera(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
    assert np.sqrt(np.mean((xm - xt) ** 2)) <= 0.014
    assert result.dispersion.anchored
    assert result.dispersion.leave_one_out_max_px <= 0.5


@pytest.fixture(scope="module")
def noisy(tmp_path_factory):
    """The noisy N-BK7 bench's sweeps and lamp frames (``tests/rigs/lamps-noisy-nbk7.yaml``:
    52 px, 9 e- read noise, 20k e- full well, contrast 400), captured once."""
    rig = open_rig("tests/rigs/lamps-noisy-nbk7.yaml")
    data = tmp_path_factory.mktemp("noisy")
    proc = load_procedure("spectral_calibration")
    sweeps = capture_spectral_sweeps(rig, proc, session_id="noisy", data=data, progress=False)
    return rig, sweeps


def _map_error_nm(rig, result):
    error = truth(rig).wavelength_map_error_nm(result.dispersion.model)
    return float(np.sqrt(np.mean(error**2))), float(np.abs(error).max())


def test_a_lamp_that_cannot_pin_a_laser_leaves_it_at_its_label(noisy):
    """A lamp only adds information: at about 12 nm a pixel the Ne lines near 670 nm blend,
    and the 670 nm line the lamps measure at +-0.42 nm keeps its label when the procedure
    asks for 0.3 nm; the bundle publishes, the lamps' estimate recorded and explained."""
    rig, sweeps = noisy
    default = analyse_spectral_sweeps(
        sweeps, load_procedure("spectral_calibration"), rig.description
    )
    assert default.passed, [c.describe() for c in default.checks if not c.passed]
    # Measured: 0.015 nm RMS, 0.089 nm worst over the field.
    rms, worst = _map_error_nm(rig, default)
    assert rms <= 0.03 and worst <= 0.18
    strict = load_procedure("spectral_calibration")
    strict["tolerances"]["laser_wavelength_sigma_nm"] = 0.3
    result = analyse_spectral_sweeps(sweeps, strict, rig.description)
    assert result.passed, [c.describe() for c in result.checks if not c.passed]
    assert 670.0 in result.anchoring.unpinned
    assert result.dispersion.wavelengths_nm[670.0] == pytest.approx(670.0, abs=0.005)
    assert result.anchoring.method(670.0) == "label (lamps cannot pin it)"
    # Measured: 0.015 nm RMS, 0.090 nm worst, as with the line measured.
    rms, worst = _map_error_nm(rig, result)
    assert rms <= 0.03 and worst <= 0.18
    (note,) = [n for n in laser_line_notes(result) if n.startswith("laser 670 nm")]
    assert "cannot pin it within 0.3 nm" in note and "lamp frames" in note


def test_a_wrong_glass_in_the_description_fails_a_check(noisy):
    """The noisy N-BK7 bench described with F2: the map is 1.25 nm RMS (4.0 nm worst) off
    the truth while the lamp lines sit within 0.003 of their FWHM (the lasers absorb the
    glass); the blue HgAr line is many of its own sigmas off, and the note names the glass."""
    rig, sweeps = noisy
    desc = rig.description
    wrong = dataclasses.replace(desc, prism=dataclasses.replace(desc.prism, glass="F2"))
    result = analyse_spectral_sweeps(sweeps, load_procedure("spectral_calibration"), wrong)
    assert _map_error_nm(rig, result)[0] > 1.0
    failed = {c.name: c for c in result.checks if not c.passed}
    # Measured: HgAr 404.7 nm 9.8 of its sigmas off (11 before the virtual bench's dense
    # frames lost their 0.005 px offset; with N-BK7: 1.6 at most).
    assert set(failed) == {"lamp_line_max_sigmas"}, [c.describe() for c in result.checks]
    assert failed["lamp_line_max_sigmas"].value > 1.5 * failed["lamp_line_max_sigmas"].tolerance
    (note,) = [n for n in spectral_notes(result) if n.startswith("lamp line")]
    assert "HgAr 404.7 nm" in note and "glass may not be the one described (F2)" in note
    assert "prism.glass" in note


@pytest.mark.xfail(
    strict=True,
    reason="information the bench does not give: with only its diodes' labels (+-5 nm) the "
    "frames fit N-SF11 as well as N-BK7 (laser maps 0.001 px RMS, lamp chi-squares equal to "
    "three decimals), the red lasers absorbing the glass; see the test below and "
    "docs/notes/2026-11-30-wrong-glass-spread.md",
)
def test_a_far_wrong_glass_in_the_description_fails_a_check(noisy):
    rig, sweeps = noisy
    desc = rig.description
    wrong = dataclasses.replace(desc, prism=dataclasses.replace(desc.prism, glass="N-SF11"))
    result = analyse_spectral_sweeps(sweeps, load_procedure("spectral_calibration"), wrong)
    assert _map_error_nm(rig, result)[0] > 1.0
    assert not result.passed


def test_lasers_stated_to_their_test_sheets_catch_a_far_wrong_glass(noisy):
    """Stated to 0.3 nm, the red lasers cannot absorb the glass: the lamps measure them
    nm off their lines, the check fails and its note names the glass first."""
    rig, sweeps = noisy
    desc = dataclasses.replace(rig.description, laser_tolerance_nm=0.3)
    wrong = dataclasses.replace(desc, prism=dataclasses.replace(desc.prism, glass="N-SF11"))
    result = analyse_spectral_sweeps(sweeps, load_procedure("spectral_calibration"), wrong)
    assert _map_error_nm(rig, result)[0] > 1.0
    failed = {c.name for c in result.checks if not c.passed}
    # Measured: 635 and 670 nm put 2.1 and 4.2 nm off their lines, 450-532 nm within 0.1.
    assert failed == {"laser_label_635nm", "laser_label_670nm"}, failed
    (note,) = [n for n in spectral_notes(result) if n.startswith("laser 635, 670 nm: the lamps")]
    assert "glass may not be the one described (N-SF11)" in note and "test sheet" in note
    right = analyse_spectral_sweeps(sweeps, load_procedure("spectral_calibration"), desc)
    assert right.passed, [c.describe() for c in right.checks if not c.passed]


def test_the_right_glass_passes_the_lamp_line_and_map_checks(noisy):
    rig, sweeps = noisy
    result = analyse_spectral_sweeps(
        sweeps, load_procedure("spectral_calibration"), rig.description
    )
    checks = {c.name: c for c in result.checks}
    # Measured: 1.6 sigma at most (F2: 11); the map states +-0.0004 px, 0.005 nm.
    assert checks["lamp_line_max_sigmas"].value < 3.2
    assert checks["map_sigma_px"].passed and checks["map_sigma_nm"].passed
    assert not any(n.startswith("lamp line") for n in spectral_notes(result))


def test_the_lamp_step_records_what_it_took_and_states_an_honest_uncertainty(anchored):
    """The lamp step stops after its first batch when every laser is pinned, records why,
    and the 1-sigma it states for each laser covers the laser's distance to the truth."""
    rig, _, bundle = anchored
    quality = bundle.manifest["quality"]
    spectral = quality.get("spectral", quality)
    taken = spectral["lamp_frames"]
    assert taken["outcome"] == "tolerance met" and taken["advice"] is None
    assert taken["frames_per_lamp"] == 4 and len(taken["batches"]) == 1
    assert max(taken["sigma_nm"].values()) <= taken["tolerance_nm"]
    t = truth(rig)
    z = {
        label: (line["measured_nm"] - t.laser_centre_nm(float(label))) / line["sigma_nm"]
        for label, line in spectral["laser_lines"].items()
    }
    # Honest: no laser further from the truth than its stated 1-sigma allows (measured
    # |z| <= 0.59), and the sigmas not inflated (measured RMS z 0.41; a 1-sigma stated
    # 4 times too large would give about 0.1).
    values = np.array(list(z.values()))
    assert np.abs(values).max() <= 1.5, z
    assert np.sqrt(np.mean(values**2)) >= 0.2, z


def test_a_noisy_bench_takes_lamp_frames_until_its_laser_is_pinned(noisy, tmp_path):
    """Asked for 0.3 nm, the noisy N-BK7 bench's 670 nm line (+-0.42 nm from 4 frames)
    takes more lamp frames; its stated 1-sigma falls and still covers the truth."""
    rig, sweeps = noisy
    proc = planned_spectral(load_procedure("spectral_calibration"), rig.description)
    proc["tolerances"]["laser_wavelength_sigma_nm"] = 0.3
    proc["lamps"]["max_frames"] = 12
    session = open_lamp_session(rig, proc, "strict-lamps", data=tmp_path)
    measurement = lamp_measurement(sweeps, proc, rig.description)
    record = capture_lamp_frames(rig, session, proc, measurement.sigma_nm, progress=False)
    first, last = record.batches[0], record.batches[-1]
    assert first.frames == 4 and first.sigma_nm[670.0] > 0.3
    assert record.frames > 4 and last.sigma_nm[670.0] < first.sigma_nm[670.0]
    assert (record.outcome == "tolerance met") == (last.sigma_nm[670.0] <= 0.3)
    assert captured_lamp_frames(session) == record.frames
    fit = measurement.measure(session, record.frames)[1]
    t = truth(rig)
    z = (fit.wavelengths_nm - [t.laser_centre_nm(x) for x in fit.labels_nm]) / fit.sigma_nm
    # Measured: batches of 4, 8 and 10 frames, 670 nm at +-0.41, 0.33 and 0.298 nm; |z| <= 1.48
    # against the truth, RMS z 1.1 (an honest 1-sigma gives about 1).
    assert np.abs(z).max() <= 3.0, z
    assert np.sqrt(np.mean(z**2)) >= 0.5, z
