"""The spectral calibration on a rig described as an optical design (the singlet arm:
strong chromatic, field-dependent and elliptical spots), scored against the bench's truth.

The lamp pinholes sit 160 SLM px apart: the design's streaks are 125 px long (the shipped
procedure's 100 px pitch is made for ``sim``'s 68 px streaks and is refused here).
"""

import copy
import itertools
import json

import numpy as np
import pytest

from sassi_bench.acquire.plan_geometry import planned_guide
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.calibrate.guide_registration import field_discrepancy_px, register_guide
from sassi_bench.calibrate.guide_render import (
    render_rgb,
    rendering_sensitivities,
    upsample_lattice,
)
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.blur_frames import BlurMeasurement, captured_blur_frames
from sassi_bench.reduce.lamps import FORM_MISFIT_NM
from sassi_bench.reduce.spectral import analyse_spectral_sweeps, laser_line_notes, spectral_notes
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.guide import capture_guide
from sassi_bench.workflows.spectral import (
    capture_blur_frames,
    capture_lamp_field_frames,
    capture_spectral_sweeps,
    run_spectral_calibration,
)


@pytest.fixture(scope="module")
def calibrated(design_rigs, tmp_path_factory):
    rig = design_rigs("singlet")
    procedure = load_procedure("spectral_calibration")
    procedure["lamps"]["pinhole_pitch_px"] = [160, 24]
    data = tmp_path_factory.mktemp("data-singlet")
    result = run_spectral_calibration(
        rig, procedure, data=data, progress=False, session_id="acc", allow_failed=True
    )
    return rig, result, data


def test_positions_and_wavelengths_hold_on_real_optics(calibrated):
    rig, result, _ = calibrated
    t = truth(rig)
    worst = 0.0
    for d in result.lasers:
        x, y = t.slm_to_camera(d.slm_u, d.slm_v, t.laser_centre_nm(d.wavelength_nm))
        worst = max(worst, float(np.sqrt(np.mean((x - d.camera_x) ** 2 + (y - d.camera_y) ** 2))))
    error_nm = t.wavelength_map_error_nm(result.dispersion.model)
    rms = float(np.sqrt(np.mean(error_nm**2)))
    print(f"correspondences worst laser RMS {worst:.3f} px; wavelength map RMS {rms:.3f} nm")
    # measured: correspondences 0.044 px (the target 0.05), map 0.038 nm RMS
    assert worst < 0.10
    assert rms < 0.07


def _worst_blur_error(t, model, slm_shape, band) -> tuple[float, float]:
    """The blur model's worst error against the bench's spots, along and across the
    streak (px), over a 9 x 5 field grid and ``band`` = (first nm, last nm, count)."""
    h, w = slm_shape
    u, v = np.meshgrid(np.linspace(0, w - 1, 9), np.linspace(0, h - 1, 5))
    u, v = u.ravel()[:, None], v.ravel()[:, None]
    lam = np.linspace(*band)[None, :]
    cxx, cyy, _ = t.spot_covariance(u, v, lam)
    spot = model.spot(u, v, lam)
    along = np.abs(np.sqrt(spot.along**2 + 1 / 12) - np.sqrt(cxx)).max()
    across = np.abs(np.sqrt(spot.across**2 + 1 / 12) - np.sqrt(cyy)).max()
    return float(along), float(across)


def test_the_field_blur_follows_the_spot_between_the_lasers(calibrated):
    rig, result, _ = calibrated
    t = truth(rig)
    model = result.blur.model
    assert model.kind == "field_covariance"
    along, across = _worst_blur_error(t, model, rig.slm.shape, (450.0, 670.0, 23))
    print(f"blur over the field, 450-670 nm: along {along:.3f} px, across {across:.3f} px")
    # measured: along 0.024 px, across 0.018 px with the lamp lines' spots (the series
    # in 1/λ²; 0.037 / 0.020 and 0.025 / 0.032 px on other draws of the noise); along
    # 0.079 px, across 0.035 px from the lasers alone (in λ), 6 pinhole frames per laser
    # (0.043 / 0.038 px on another draw of the noise, 3 frames; the widest round spot
    # misses by 0.96 px).
    # Held to the target, 0.1 px: the field model's own floor is about 0.05 px.
    # With the blur pinholes 20 SLM px short of the edges it was 0.27 / 0.12 px: the fit
    # extrapolated the pinholes' noise to the edges.
    assert along < 0.1
    assert across < 0.06


def test_the_blur_step_stops_once_its_stated_uncertainty_meets_the_tolerance(calibrated):
    _, result, _ = calibrated
    record = result.blur_record
    # measured: 0.025 px from the sweep's 2 frames (tolerance 0.05), so no blur session
    assert [b.frames for b in record.batches] == [2]
    assert record.outcome == "tolerance met" and record.sigma_px <= 0.05
    assert not any(s.id == "acc-blur" for s in result.sessions)
    # the analysis's fit adds the lamp lines' spots: its stated 1-sigma spans their band
    # too, down to 404.7 nm, where fewer and dimmer spots pin it (measured: 0.036 px, the
    # step's lasers-only fit 0.025 px)
    assert result.blur.width_sigma_px > record.sigma_px
    quality = load(result.bundle_path).manifest["quality"]
    spectral = quality.get("spectral", quality)
    assert spectral["blur_frames"]["frames_per_laser"] == 2
    assert any(note.startswith("blur frames: 2") for note in spectral["notes"])


def test_the_lamp_field_step_takes_lamp_frames_until_the_blue_widths_are_pinned(calibrated):
    """Past the lasers' band the field blur leans on the dim HgAr lines, whose spots
    scatter several times a laser's: the fit states its widths there from each line's
    own scatter, and the lamp field step takes frames until that meets the tolerance."""
    _, result, _ = calibrated
    record = result.lamp_field_record
    frames = [b.frames for b in record.batches]
    print("lamp field frames", frames, [round(b.sigma_px, 4) for b in record.batches])
    assert frames[0] == result.procedure["lamps"]["frames"]
    assert all(b > a for a, b in itertools.pairwise(frames)) and frames[-1] <= record.budget
    if record.outcome == "tolerance met":
        assert record.sigma_px <= record.tolerance_px
    else:
        assert record.advice() is not None
    # the analysis states the same fit's uncertainty from the same spots, placed by the
    # lamp-anchored map instead of the labels'
    assert result.blur.width_sigma_px == pytest.approx(record.sigma_px, rel=0.2)
    quality = load(result.bundle_path).manifest["quality"]
    spectral = quality.get("spectral", quality)
    assert spectral["lamp_field_frames"]["frames_per_offset"] == frames[-1]
    assert any(n.startswith(f"lamp field frames: {frames[-1]} ") for n in spectral["notes"])


def test_a_resumed_lamp_field_step_replays_its_decisions_and_captures_nothing(calibrated):
    rig, result, data = calibrated
    sweep = next(s for s in result.sessions if s.id == "acc-sweep")
    lamps = Session.open("acc-lamps", data=data)
    stored = sorted(lamps.completed)
    measurement = BlurMeasurement(
        sweep, result.procedure, rig.description, [d.laser_map for d in result.lasers]
    )
    replayed = capture_lamp_field_frames(
        rig, lamps, result.procedure,
        lambda session, n: measurement.fit(None, None, session, n).width_sigma_px,
        progress=False,
    )  # fmt: skip
    record = result.lamp_field_record
    assert [(b.frames, b.outcome) for b in replayed.batches] == [
        (b.frames, b.outcome) for b in record.batches
    ]
    assert sorted(Session.open("acc-lamps", data=data).completed) == stored


@pytest.fixture(scope="module")
def strict_blur(calibrated):
    """The blur step asked for a fifth under what the sweep's frames state, under the
    floor of this bench's field blur from the lasers (measured 1-sigma 0.0301, 0.0277,
    0.0246, 0.0260, 0.0266 px from 2, 4, 6, 7 and 8 frames per laser, asked for 0.0241
    px; another draw of the noise: 0.0249, 0.0256, 0.0242 px from 2, 4 and 7)."""
    rig, result, data = calibrated
    sweep = next(s for s in result.sessions if s.id == "acc-sweep")
    proc = copy.deepcopy(result.procedure)
    proc["tolerances"]["blur_width_sigma_px"] = 0.8 * result.blur_record.batches[0].sigma_px
    measurement = BlurMeasurement(
        sweep, proc, rig.description, [d.laser_map for d in result.lasers]
    )
    session, record = capture_blur_frames(
        rig, sweep, proc, measurement, "acc-strict-blur", data=data, progress=False
    )
    return rig, sweep, proc, measurement, session, record, data


def test_the_blur_step_stops_at_a_floor_frames_do_not_lower(strict_blur):
    *_, session, record, _ = strict_blur
    frames = [b.frames for b in record.batches]
    assert frames[0] == 2 and len(frames) >= 3
    assert all(b > a for a, b in itertools.pairwise(frames)) and frames[-1] <= record.budget
    # the 1-sigma does not fall as photons would have it (whether the rule reads the
    # floor before the budget is spent depends on the draw: tests/reduce hold the rule)
    assert record.outcome in ("out of reach", "budget spent")
    assert record.sigma_px > record.tolerance_px
    first = record.batches[0]
    photons = first.sigma_px * (first.frames / frames[-1]) ** 0.5
    assert min(b.sigma_px for b in record.batches) > 1.4 * photons
    assert record.advice() is not None
    assert captured_blur_frames(session) == frames[-1]


def test_a_resumed_blur_step_replays_its_decisions_and_captures_nothing(strict_blur):
    rig, sweep, proc, measurement, _, record, data = strict_blur
    stored = sorted(Session.open("acc-strict-blur", data=data).completed)
    again, replayed = capture_blur_frames(
        rig, sweep, proc, measurement, "acc-strict-blur", data=data, progress=False
    )
    assert replayed == record
    assert sorted(again.completed) == stored


def test_a_bench_built_to_its_design_is_reported_matching_it(calibrated):
    """The calibration report's comparison of the measured maps with the described design
    (the bench here is built to it)."""
    _, result, _ = calibrated
    found = result.design_comparison
    print(found.verdict)
    assert found.matches, found.verdict
    assert any(note.startswith("as designed against as built: ") for note in spectral_notes(result))
    manifest = json.loads((result.bundle_path / "manifest.json").read_text())
    assert manifest["quality"]["design_comparison"]["matches"] is True
    assert (result.bundle_path / "report" / "design_comparison.png").is_file()


@pytest.fixture(scope="module")
def achromat(design_rigs, tmp_path_factory):
    """The achromat arm's sweeps and lamp frames, captured once, and their analysis."""
    rig = design_rigs("achromat")
    procedure = load_procedure("spectral_calibration")
    data = tmp_path_factory.mktemp("data-achromat")
    sweeps = capture_spectral_sweeps(rig, procedure, session_id="acc", data=data, progress=False)
    return rig, analyse_spectral_sweeps(sweeps, procedure, rig.description)


def test_the_achromat_s_wavelength_map_holds_where_its_lamp_lines_blend(achromat):
    """At the achromat's red end (0.15 px/nm, 2 px spots) the Ne lines blend and the
    lamp-anchored measurement of the 635 and 670 nm lasers follows the column model's
    form, not the data: it moves by nanometres when the model gains a power, so those
    lines keep their labels, and the map holds against the bench's truth."""
    rig, result = achromat
    anchoring = result.anchoring
    print({k: round(v, 3) for k, v in anchoring.form_shift_nm.items()}, anchoring.unpinned)
    # measured: form shifts -1.76 / -3.07 nm at 635 / 670 nm (0.03 to 0.15 nm for the
    # others); the quadratic alone measured them +0.37 / +0.69 nm off, stated +-0.09 / 0.14
    assert anchoring.form_misfit_nm > FORM_MISFIT_NM  # measured: 0.085 nm
    assert set(anchoring.unpinned) == {635.0, 670.0}
    assert set(anchoring.confirmed) == {450.0, 520.0, 532.0}
    assert all(abs(anchoring.form_shift_nm[label]) > 1.0 for label in (635.0, 670.0))
    assert anchoring.method(670.0) == "label (lamps cannot pin it)"
    (note,) = [n for n in laser_line_notes(result) if n.startswith("laser 670 nm")]
    assert "when the column model gains a power" in note and "More lamp frames do not" in note
    t = truth(rig)
    for label, used in result.dispersion.wavelengths_nm.items():
        assert used == pytest.approx(t.laser_centre_nm(label), abs=0.01), label
    error_nm = t.wavelength_map_error_nm(result.dispersion.model)
    rms, worst = float(np.sqrt(np.mean(error_nm**2))), float(np.abs(error_nm).max())
    print(f"achromat wavelength map: {rms:.3f} nm RMS, {worst:.3f} nm worst")
    # measured: 0.063 nm RMS, 0.253 nm worst (the quadratic column model's own floor on
    # this arm, 0.060 / 0.246 nm fitted to the truth at the five lines); 0.314 / 0.939 nm
    # with the two red lines taken at the lamps' measurement.
    assert rms <= 0.1
    assert worst <= 0.45
    # A right bundle passes every check: the lamp lines sit off the map by the column
    # model's form misfit on this arm, which their 1-sigma includes (measured: 1.4 sigma;
    # 8.8 sigma on photons alone).
    failed = [c.describe() for c in result.checks if not c.passed]
    assert failed == []


def test_the_guide_scans_lattice_on_a_small_slm_keeps_the_homography(design_rigs, tmp_path):
    """The guide registration on the singlet rig's 320 x 200 SLM against the truth, with
    the scene rendered from the bench's truth on the guide scan's lattice (the scan's own
    errors left out): the derived stride keeps the homography; the 640 px SLM's [4, 1]
    lattice, too coarse for the texture of a field half as wide, moves it."""
    rig = design_rigs("singlet")
    t = truth(rig)
    procedure = planned_guide(load_procedure("guide_registration"), rig.description)
    image, valid, _ = capture_guide(rig, procedure, session_id="g", data=tmp_path, progress=False)
    edges = np.arange(400.0, 702.0, 4.0)
    wavelengths = 0.5 * (edges[1:] + edges[:-1])
    cube = t.binned_cube(edges, "led", procedure["scene"])
    sensor = rig.description.guide_camera.sensitivities
    sensitivities, _ = rendering_sensitivities(sensor, "auto", wavelengths)
    match = procedure["match"]

    def error_px(stride):
        rgb = render_rgb(cube[:: stride[1], :: stride[0]], wavelengths, sensitivities=sensitivities)
        lattice = np.ones(rgb.shape[:2], bool)
        reference, known = upsample_lattice(rgb, lattice, stride, rig.slm.shape)
        found = register_guide(
            image, np.clip(reference, 0.0, 1.0), slm_valid=known, guide_valid=valid,
            ratio=match["ratio"], method=match["method"], threshold_px=match["threshold_px"],
            min_inliers=procedure["tolerances"]["min_inliers"], min_coverage=0.25,
            sift_options={"contrastThreshold": match["contrast_threshold"]}, dense=True,
        )  # fmt: skip
        return field_discrepancy_px(found.homography, t.guide_to_slm, rig.slm.shape)[0]

    derived, coarse = error_px(tuple(procedure["scan"]["stride_px"])), error_px((4, 1))
    print(f"guide homography vs truth: derived stride {derived:.3f} px, [4, 1] {coarse:.3f} px")
    # measured: derived [2, 1] 0.032 px, [4, 1] 0.669 px (sim's 640 x 400 SLM at [4, 1]:
    # 0.049 px); the whole guide procedure on the singlet, scan included, 0.029 px.
    assert procedure["scan"]["stride_px"] == [2, 1]
    assert derived < 0.06
    assert coarse > 0.3


def test_the_bundle_names_the_band_where_the_field_blur_was_measured(calibrated):
    _, result, _ = calibrated
    quality = load(result.bundle_path).manifest["quality"]
    notes = quality.get("spectral", quality)["notes"]
    band = [n for n in notes if n.startswith("blur: measured over the field at")]
    edges = result.dispersion.bins.edges_nm
    assert band == [
        "blur: measured over the field at 7 lines, 405-670 nm; the bundle's bins reach "
        f"{edges.min():.0f}-{edges.max():.0f} nm, where its widths are extrapolated"
    ]


def test_the_lamp_lines_measure_the_field_blur_below_the_lasers(calibrated):
    """The HgAr 404.7 and 435.8 nm lines, in the lamp session's field frames (the pinhole
    grid at four offsets), measure the blur where the lasers' fit only extrapolated."""
    rig, result, _ = calibrated
    t = truth(rig)
    lamps = next(s for s in result.sessions if s.id == "acc-lamps")
    # the grid at four offsets, planned to the lamp budget, taken as the lamp field step
    # decided
    budget = lamps.plan.parameters["procedure"]["lamps"]["max_frames"]
    field = lamps.plan.select(role="lamp-field", lamp="lamp:HgAr")
    assert len(field) == 4 * budget
    taken = [i for i in field if i in lamps.completed]
    assert len(taken) == 4 * result.lamp_field_record.frames
    assert lamps.plan.select(role="lamp-field", lamp="lamp:Ne") == []
    assert result.blur.wavelengths_nm[:2].tolist() == [404.6565, 435.8335]
    model = result.blur.model
    along, across = _worst_blur_error(t, model, rig.slm.shape, (400.0, 450.0, 11))
    print(f"blur over the field, 400-450 nm: along {along:.3f} px, across {across:.3f} px")
    # measured: along 0.048 px, across 0.076 px here (lamp pitch [160, 24]; 0.046 /
    # 0.053 px on another draw of the noise); 0.035 / 0.043 px over 400-700 nm with the
    # derived pitch (the accuracy table); from the lasers alone 1.05 / 0.57 px
    assert along < 0.1
    assert across < 0.12


def test_the_field_blur_does_not_bend_past_the_last_laser(calibrated):
    """Past 670 nm no line is measured: the blur's series, in ``1/λ²`` and continued
    linearly past its outermost lines, holds the truth there."""
    rig, result, _ = calibrated
    t = truth(rig)
    model = result.blur.model
    assert model.band_nm == (404.6565, pytest.approx(670.0, abs=0.01))
    along, across = _worst_blur_error(t, model, rig.slm.shape, (670.0, 700.0, 7))
    print(f"blur over the field, 670-700 nm: along {along:.3f} px, across {across:.3f} px")
    # measured: along 0.035 px, across 0.025 px (the series in λ, degree 4, free past
    # 670 nm: 0.19 / 0.11 px on the shipped lamp pitch, see
    # docs/notes/2026-11-30-singlet-snapshot-spectra.md)
    assert along < 0.05
    assert across < 0.05
