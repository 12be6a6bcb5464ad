"""The spectral calibration workflow: laser sweeps -> dispersion and blur -> bundle.

:func:`run_spectral_calibration` drives a rig through the procedure's capture plans
(recording everything in raw sessions, resumable), decodes every laser's SLM -> camera
correspondences, fits the per-laser field maps, the joint dispersion model and the blur,
grades the result against the procedure's tolerances and (optionally) publishes a
calibration bundle with its plots. It uses device handles only.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationModels, QualityCheck, publish
from sassi_bench.bundle.derive import stage_checks
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.calibrate.blur import BlurFit, fit_blur, measure_spot_widths
from sassi_bench.calibrate.dispersion import (
    DispersionFit,
    LaserLine,
    LaserMap,
    check_laser_lines,
    fit_dispersion,
)
from sassi_bench.calibrate.field import fit_field
from sassi_bench.calibrate.grey_response import (
    GreyResponse,
    measure_grey_response,
    sinusoid_profile,
)
from sassi_bench.calibrate.line_sweep import fit_line_axis, line_centres
from sassi_bench.calibrate.structured_light import decode_axis
from sassi_bench.errors import ConfigError, ProcedureError, step_error
from sassi_bench.paths import data_root
from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.spectral_plans import grey_plan, laser_light, sweep_plan

__all__ = [
    "LaserDecode",
    "SpectralCalibration",
    "SpectralSweeps",
    "analyse_spectral_sweeps",
    "analyse_sweep",
    "capture_spectral_sweeps",
    "laser_line_notes",
    "measure_response",
    "procedure_lasers",
    "publish_spectral",
    "render_figures",
    "run_spectral_calibration",
]


@dataclass(frozen=True)
class LaserDecode:
    """What one laser's sweep gave: correspondences, their smooth map, and counts."""

    wavelength_nm: float
    camera_x: NDArray[np.float64]
    camera_y: NDArray[np.float64]
    slm_u: NDArray[np.float64]
    slm_v: NDArray[np.float64]
    valid_fraction: float
    counts: dict[str, int]
    laser_map: LaserMap
    residual_rms_px: float
    """Scatter of the raw measurements about the smooth map, camera px: decoded pixels
    about the field fit (structured), line centres about their fits (lines)."""


@dataclass
class SpectralCalibration:
    """Everything the spectral calibration produced."""

    procedure: dict[str, Any]
    rig_description: Any
    lasers: list[LaserDecode]
    dispersion: DispersionFit
    blur: BlurFit
    grey_response: GreyResponse | None
    checks: list[QualityCheck]
    sessions: list[Session]
    bundle_path: Path | None = None
    figures: dict[str, bytes] = field(default_factory=dict)
    laser_lines: dict[float, LaserLine] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """Whether every quality check passed."""
        return all(c.passed for c in self.checks)

    def models(self) -> CalibrationModels:
        """The bundle models of this calibration."""
        return CalibrationModels(
            dispersion=self.dispersion.model, bins=self.dispersion.bins, blur=self.blur.model
        )


def _session_id(base: str | None) -> str:
    if base:
        return base
    return "spectral-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")


def procedure_lasers(procedure: Mapping[str, Any], lasers_nm) -> list[float]:
    """The laser lines a spectral calibration sweeps: the procedure's ``lasers_nm`` when it
    pins them, else every laser of the rig (``lasers_nm``, from its description).

    Examples
    --------
    >>> procedure_lasers({"lasers_nm": None}, (405, 488, 561, 640))
    [405.0, 488.0, 561.0, 640.0]
    >>> procedure_lasers({"lasers_nm": [450, 532, 670]}, (450, 520, 532, 635, 670))
    [450.0, 532.0, 670.0]
    """
    pinned = procedure.get("lasers_nm")
    return [float(x) for x in (pinned if pinned is not None else lasers_nm)]


def _check_lasers(rig: Rig, lasers: list[float]) -> None:
    missing = [x for x in lasers if laser_light(x) not in rig.light.available]
    if missing:
        raise ConfigError(
            step_error(
                "spectral calibration",
                f"the procedure needs laser line(s) {missing} nm that rig "
                f"{rig.description.name!r} does not have ({', '.join(rig.light.available)})",
                "add them to the rig's lasers_nm or remove them from the procedure's lasers_nm",
            )
        )


def _resume(session_id: str, data) -> Session | None:
    """The existing session of this id, or None if there is none (damage is an error)."""
    if not (data_root(data) / "sessions" / session_id).exists():
        return None
    return Session.open(session_id, data=data)


def _capture_settings(proc: Mapping[str, Any]) -> dict[str, Any]:
    """The parts of a procedure that decide what is captured, as JSON values (so 450 and
    450.0 nm are the same laser). Fit settings and tolerances may change between capture
    and analysis (a person excluding a region in the notebook); these may not."""
    blur = {k: v for k, v in thaw(proc.get("blur", {})).items() if k != "window_sigmas"}
    settings = {k: thaw(proc.get(k)) for k in ("lasers_nm", "sweep", "exposure")}
    return json.loads(json.dumps({**settings, "blur": blur}))


def _check_same_procedure(session: Session, proc: Mapping[str, Any], rig_lasers) -> None:
    """Refuse to resume ``session`` with a procedure that would capture other frames; a
    procedure that leaves ``lasers_nm`` to the rig equals one pinning the rig's lasers."""
    stored = session.plan.parameters.get("procedure")

    def settings(procedure: Mapping[str, Any]) -> dict[str, Any]:
        lasers = procedure_lasers(procedure, rig_lasers)
        return _capture_settings({**procedure, "lasers_nm": lasers})

    if stored is not None and settings(stored) != settings(proc):
        raise ConfigError(
            step_error(
                f"resume session {session.id}",
                "it was captured with different lasers, sweep, exposure or blur settings "
                "than the procedure given now",
                "resume with the same procedure file, or start a new --session",
            )
        )


def _frames(session: Session, indices: list[int]) -> NDArray[np.float32]:
    return session.read_frames(indices).astype(np.float32)


def _one(session: Session, **tags) -> NDArray[np.float32]:
    indices = session.plan.select(**tags)
    if not indices:
        raise ProcedureError(
            step_error("spectral analysis", f"no frame tagged {tags}", "re-run the capture")
        )
    return _frames(session, indices).mean(axis=0)


def measure_response(session: Session, saturation: float) -> GreyResponse:
    """The SLM's grey-level response from a grey-level session."""
    plan = session.plan
    indices = plan.select(role="grey")
    levels = [plan.steps[i].tags["level"] for i in indices]
    dark = _one(session, role="dark")
    return measure_grey_response(
        levels, _frames(session, indices), dark, saturation_level=saturation
    )


def _lit(full: NDArray, blank: NDArray) -> NDArray[np.bool_]:
    """Camera pixels the open SLM lights (the denominator of the valid fraction)."""
    signal = full - blank
    return signal > 0.1 * np.percentile(signal, 99.5)


def _structured_decode(session: Session, proc, laser: float, slm_shape, saturation):
    sweep = proc["sweep"]
    plan = session.plan
    dark = _one(session, role="dark", laser=laser)
    blank = _one(session, role="blank", laser=laser)
    full = _one(session, role="full", laser=laser)
    axes = {}
    for axis, length in (("x", slm_shape[1]), ("y", slm_shape[0])):
        pos = plan.select(role="gray", laser=laser, axis=axis, inverse=False)
        neg = plan.select(role="gray", laser=laser, axis=axis, inverse=True)
        phase = plan.select(role="phase", laser=laser, axis=axis)
        axes[axis] = decode_axis(
            _frames(session, pos),
            _frames(session, neg),
            _frames(session, phase),
            blank=blank,
            full=full,
            length=length,
            dark=dark,
            block=int(sweep.get("gray_block_px", 8)),
            period=int(sweep.get("phase_period_px", 16)),
            saturation_level=saturation,
            min_modulation=float(sweep.get("min_modulation", 0.2)),
        )
    valid = axes["x"].valid & axes["y"].valid
    lit = _lit(full, blank)
    rows, cols = np.nonzero(valid)
    counts = {f"{axis}_{k}": v for axis, dec in axes.items() for k, v in dec.counts.items()}
    return (
        cols.astype(np.float64),
        rows.astype(np.float64),
        axes["x"].coord[rows, cols],
        axes["y"].coord[rows, cols],
        float((valid & lit).sum() / max(lit.sum(), 1)),
        counts,
    )


def _line_decode(session: Session, proc, laser: float, slm_shape, saturation):
    sweep = proc["sweep"]
    plan = session.plan
    blank = _one(session, role="blank", laser=laser)
    full = _one(session, role="full", laser=laser)
    camera_shape = blank.shape
    fits = {}
    skipped = 0
    for axis, length in (("x", slm_shape[1]), ("y", slm_shape[0])):
        indices = plan.select(role="line", laser=laser, axis=axis)
        offsets = [plan.steps[i].tags["offset"] for i in indices]
        signals = [session.read_frame(i).astype(np.float32) - blank for i in indices]
        centres = line_centres(
            signals, offsets, int(sweep.get("line_spacing_px", 64)), axis, length
        )
        skipped += centres.skipped_frames
        fits[axis] = fit_line_axis(centres, camera_shape, int(proc["fit"].get("field_degree", 5)))
    lit = _lit(full, blank)
    rows, cols = np.nonzero(lit)
    x, y = cols.astype(np.float64), rows.astype(np.float64)
    u, v = fits["x"](x, y), fits["y"](x, y)
    inside = (u >= 0) & (u <= slm_shape[1] - 1) & (v >= 0) & (v <= slm_shape[0] - 1)
    counts = {"skipped_frames": skipped, "outside_slm": int((~inside).sum())}
    counts.update({f"{a}_line_fit_rms_slm_px": round(f.rms, 4) for a, f in fits.items()})
    return x[inside], y[inside], u[inside], v[inside], float(inside.mean()), counts


def excluded_regions(u: NDArray, v: NDArray, regions) -> NDArray[np.bool_]:
    """Whether SLM points (u, v) fall in any [row0, col0, row1, col1] rectangle.

    Examples
    --------
    >>> excluded_regions(np.array([5.0, 50.0]), np.array([5.0, 5.0]), [[0, 0, 10, 10]]).tolist()
    [True, False]
    """
    out = np.zeros(np.shape(u), dtype=bool)
    for row0, col0, row1, col1 in regions:
        out |= (v >= row0) & (v < row1) & (u >= col0) & (u < col1)
    return out


def analyse_sweep(
    session: Session, proc: Mapping[str, Any], slm_shape: tuple[int, int], saturation: float
) -> list[LaserDecode]:
    """Decode every laser of a sweep session and fit its smooth field map."""
    degree = int(proc["fit"].get("field_degree", 5))
    out = []
    lasers = sorted(
        {float(s.tags["laser"]) for s in session.plan.steps if s.tags.get("role") == "full"}
    )
    for laser in lasers:
        decode = _structured_decode if proc["sweep"]["mode"] == "structured" else _line_decode
        x, y, u, v, fraction, counts = decode(session, proc, laser, slm_shape, saturation)
        if x.size < 1000:
            raise ProcedureError(
                step_error(
                    f"sweep decoding at {laser:g} nm",
                    f"only {x.size} camera pixels decoded ({counts})",
                    "check the exposure (saturated or too dark frames) and the laser",
                )
            )
        keep = ~excluded_regions(u, v, proc["fit"].get("exclude_regions_slm_px", []))
        x, y, u, v = x[keep], y[keep], u[keep], v[keep]
        fx = fit_field(u, v, x, slm_shape, degree)
        fy = fit_field(u, v, y, slm_shape, degree)
        if "x_line_fit_rms_slm_px" in counts:
            # Line centres scatter in SLM px; convert with the local magnification.
            h, w = slm_shape
            scale = float(np.diff(fx(np.array([w / 2 - 1, w / 2 + 1]), h / 2))[0] / 2)
            slm_rms = np.hypot(counts["x_line_fit_rms_slm_px"], counts["y_line_fit_rms_slm_px"])
            residual = float(slm_rms * abs(scale))
        else:
            residual = float(np.hypot(fx.rms, fy.rms))
        laser_map = LaserMap(laser, fx, fy, x.size, counts)
        out.append(LaserDecode(laser, x, y, u, v, fraction, counts, laser_map, residual))
    return out


def _blur_fit(session: Session, proc, dispersion: DispersionFit, slm_shape, saturation) -> BlurFit:
    plan = session.plan
    pitch = [int(p) for p in proc["blur"].get("pinhole_pitch_px", [40, 40])]
    lasers = sorted(
        {float(s.tags["laser"]) for s in plan.steps if s.tags.get("role") == "pinholes"}
    )
    sigmas = []
    for laser in lasers:
        indices = plan.select(role="pinholes", laser=laser)
        frames = _frames(session, indices)
        signal = frames.mean(axis=0) - _one(session, role="blur-blank", laser=laser)
        pattern_rows, pattern_cols = np.mgrid[
            pitch[1] // 2 : slm_shape[0] : pitch[1], pitch[0] // 2 : slm_shape[1] : pitch[0]
        ]
        wavelength = dispersion.wavelengths_nm.get(laser, laser)
        x, y = dispersion.model.evaluate(pattern_cols.ravel(), pattern_rows.ravel(), wavelength)
        widths = measure_spot_widths(
            signal, x, y, 1.5, saturated=(frames >= saturation).any(axis=0)
        )
        sigmas.append(widths.median_sigma_y)
    wavelengths = [dispersion.wavelengths_nm.get(laser, laser) for laser in lasers]
    return fit_blur(wavelengths, sigmas, float(proc["blur"].get("window_sigmas", 3.0)))


def grade(
    result_lasers,
    dispersion: DispersionFit,
    blur: BlurFit,
    tolerances: Mapping,
    laser_lines: Mapping[float, LaserLine] | None = None,
) -> list[QualityCheck]:
    """Quality checks of a spectral calibration against the procedure's tolerances.

    ``laser_lines`` (from :func:`~sassi_bench.calibrate.dispersion.check_laser_lines`)
    adds one check per line fitted at its label, ``laser_line_<label>nm``: how far the
    other lines put it from its label. A line fitted at its estimate has no such check
    (it agrees with the others by construction); the bundle records its estimate.
    """
    checks = []
    for laser in result_lasers:
        name = f"{laser.wavelength_nm:g}nm"
        checks.append(
            QualityCheck.at_most(
                f"correspondence_rms_{name}",
                laser.residual_rms_px,
                tolerances["correspondence_rms_px"],
                "px",
            )
        )
        checks.append(
            QualityCheck.at_least(
                f"valid_fraction_{name}",
                laser.valid_fraction,
                tolerances["valid_fraction_min"],
                "1",
            )
        )
    estimated = set(dispersion.estimated_lines)
    for label, line in (laser_lines or {}).items():
        if label not in estimated and np.isfinite(line.estimated_nm):
            checks.append(
                QualityCheck.at_most(
                    f"laser_line_{label:g}nm",
                    abs(line.offset_nm),
                    tolerances.get("laser_line_nm", 0.5),
                    "nm",
                )
            )
    if dispersion.leave_one_out:
        checks.append(
            QualityCheck.at_most(
                "leave_one_out_rms_nm",
                dispersion.leave_one_out_rms_nm,
                tolerances["leave_one_out_rms_nm"],
                "nm",
            )
        )
        checks.append(
            QualityCheck.at_most(
                "leave_one_out_max_px",
                dispersion.leave_one_out_max_px,
                tolerances["leave_one_out_max_px"],
                "px",
            )
        )
    checks.append(
        QualityCheck.at_most("blur_fit_rms_px", blur.rms_px, tolerances["blur_fit_rms_px"], "px")
    )
    return checks


@dataclass(frozen=True)
class SpectralSweeps:
    """The raw sessions of a spectral calibration: the grey-level response (structured
    sweeps only) and the laser sweep itself."""

    grey: Session | None
    sweep: Session

    @property
    def sessions(self) -> list[Session]:
        """The sessions, in capture order."""
        return [s for s in (self.grey, self.sweep) if s is not None]


def capture_spectral_sweeps(
    rig: Rig,
    procedure: Mapping[str, Any],
    *,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> SpectralSweeps:
    """Capture (or resume) the laser sweeps of a spectral calibration.

    Parameters
    ----------
    rig
        Device handles (virtual or real).
    procedure
        A validated spectral-calibration procedure
        (:func:`~sassi_bench.workflows.procedure.load_procedure`).
    session_id
        Base id of the raw sessions (``<id>-grey``, ``<id>-sweep``); an existing id
        resumes its capture (the stored plans are reused, not rebuilt).
    data
        Data root for sessions.

    Returns
    -------
    SpectralSweeps

    Examples
    --------
    >>> sweeps = capture_spectral_sweeps(rig, proc, session_id="lab-2026-11-22")  # doctest: +SKIP
    """
    proc = dict(procedure)
    lasers = procedure_lasers(proc, rig.description.lasers_nm)
    extra = [float(x) for x in proc["blur"].get("extra_lasers_nm", [])]
    _check_lasers(rig, lasers + extra)
    base = _session_id(session_id)
    slm_shape = rig.slm.shape
    saturation = 2**rig.spectral_camera.bit_depth - 1
    exp_cfg = proc.get("exposure", {})

    def expose(laser: float, pattern: Mapping) -> float:
        rig.set_scene("white")
        return auto_exposure(
            rig,
            laser_light(laser),
            pattern,
            target_fraction=float(exp_cfg.get("target_fraction", 0.6)),
            start_s=float(exp_cfg.get("start_s", 0.01)),
            max_s=float(exp_cfg.get("max_s", 2.0)),
        )

    grey = _resume(f"{base}-grey", data)
    sweep = _resume(f"{base}-sweep", data)
    for existing in (grey, sweep):
        if existing is not None:
            _check_same_procedure(existing, proc, rig.description.lasers_nm)
    exposures: dict[float, float] = {}
    if sweep is None:
        exposures = {laser: expose(laser, {"kind": "full"}) for laser in lasers}
    if proc["sweep"]["mode"] == "structured":
        middle = lasers[len(lasers) // 2]
        if grey is None:
            plan = grey_plan(
                proc, middle, exposures.get(middle) or expose(middle, {"kind": "full"})
            )
            grey = Session.create(rig.description, plan, session_id=f"{base}-grey", data=data)
        run_plan(rig, grey.plan, grey, progress=progress)
    if sweep is None:
        # The sinusoids are precompensated for the SLM's measured grey-level response.
        response = measure_response(grey, saturation) if grey is not None else None
        pitch = [int(p) for p in proc["blur"]["pinhole_pitch_px"]]
        pinholes = {"kind": "pinholes", "pitch": pitch, "offset": [pitch[0] // 2, pitch[1] // 2]}
        blur_exposures = {laser: expose(laser, pinholes) for laser in lasers + extra}
        period = int(proc["sweep"]["phase_period_px"])
        profile = sinusoid_profile(period, response).tolist() if response is not None else None
        plan = sweep_plan(proc, slm_shape, exposures, profile, blur_exposures)
        sweep = Session.create(rig.description, plan, session_id=f"{base}-sweep", data=data)
    run_plan(rig, sweep.plan, sweep, progress=progress)
    return SpectralSweeps(grey, sweep)


def analyse_spectral_sweeps(
    sweeps: SpectralSweeps, procedure: Mapping[str, Any], rig_description: Any
) -> SpectralCalibration:
    """Decode the sweeps, fit the dispersion and blur models and grade them.

    Parameters
    ----------
    sweeps
        From :func:`capture_spectral_sweeps`.
    procedure
        The procedure the sweeps were captured with (fit settings and tolerances).
    rig_description
        The rig's description (SLM shape, camera bit depth, prism glass).

    Returns
    -------
    SpectralCalibration

    Examples
    --------
    >>> result = analyse_spectral_sweeps(sweeps, proc, rig.description)  # doctest: +SKIP
    >>> result.passed  # doctest: +SKIP
    True
    """
    proc = dict(procedure)
    desc = rig_description
    slm_shape = (desc.slm.height, desc.slm.width)
    saturation = 2**desc.spectral_camera.bit_depth - 1
    response = measure_response(sweeps.grey, saturation) if sweeps.grey is not None else None
    decoded = analyse_sweep(sweeps.sweep, proc, slm_shape, saturation)
    maps = [d.laser_map for d in decoded]
    shape = {
        "field_degree": int(proc["fit"].get("field_degree", 5)),
        "order": int(proc["fit"].get("dispersion_order", 2)),
    }
    lines = check_laser_lines(
        maps,
        desc.prism.glass,
        slm_shape,
        float(proc["tolerances"].get("laser_line_nm", 0.5)),
        **shape,
    )
    estimate = bool(proc["fit"].get("estimate_laser_wavelengths", False))
    dispersion = fit_dispersion(
        maps,
        desc.prism.glass,
        slm_shape,
        wavelengths_nm={k: v.estimated_nm for k, v in lines.items() if v.off_label}
        if estimate
        else None,
        **shape,
    )
    blur = _blur_fit(sweeps.sweep, proc, dispersion, slm_shape, saturation)
    checks = grade(decoded, dispersion, blur, proc["tolerances"], lines)
    return SpectralCalibration(
        proc,
        desc,
        decoded,
        dispersion,
        blur,
        response,
        checks,
        sweeps.sessions,
        laser_lines=lines,
    )


def laser_line_notes(result: SpectralCalibration) -> list[str]:
    """What the laser-line check found, one sentence per line off its label.

    Examples
    --------
    >>> laser_line_notes(result)  # doctest: +SKIP
    ['laser 635 nm: the other lines put it at 637.78 nm (+2.78 nm); ...']
    """
    notes = []
    estimated = set(result.dispersion.estimated_lines)
    tolerance = float(result.procedure["tolerances"].get("laser_line_nm", 0.5))
    for label, line in result.laser_lines.items():
        if label in estimated:
            notes.append(
                f"laser {label:g} nm: fitted at {line.estimated_nm:.2f} nm, its wavelength as "
                f"estimated from the {', '.join(f'{x:g}' for x in line.from_lines)} nm lines "
                f"({line.offset_nm:+.2f} nm from its label)"
            )
        elif abs(line.offset_nm) > tolerance:
            cause = (
                "this line is off its label"
                if line.off_label
                else "one of the lines is off its label, which cannot be told from so few lines"
            )
            notes.append(
                f"laser {label:g} nm: the {', '.join(f'{x:g}' for x in line.from_lines)} nm "
                f"lines put it at {line.estimated_nm:.2f} nm ({line.offset_nm:+.2f} nm): "
                f"{cause}. Fix: measure the line with a spectrometer and correct lasers_nm, "
                "or set fit.estimate_laser_wavelengths: true in the procedure"
            )
    return notes


def run_spectral_calibration(
    rig: Rig,
    procedure: Mapping[str, Any],
    *,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
    publish_bundle: bool = True,
    allow_failed: bool = False,
    figures: bool = True,
) -> SpectralCalibration:
    """Run the spectral calibration end to end: capture, analyse, plot, publish.

    Parameters
    ----------
    rig, procedure, session_id, data, progress
        As for :func:`capture_spectral_sweeps`.
    publish_bundle, allow_failed
        Publish a bundle; refuse one that failed its checks unless ``allow_failed``.
    figures
        Render the plots (they go into the bundle's ``report/``).

    Returns
    -------
    SpectralCalibration

    Examples
    --------
    >>> result = run_spectral_calibration(open_rig("sim"), proc)  # doctest: +SKIP
    >>> result.bundle_path  # doctest: +SKIP
    PosixPath('calib_data/sim/v0001')
    """
    sweeps = capture_spectral_sweeps(
        rig, procedure, session_id=session_id, data=data, progress=progress
    )
    result = analyse_spectral_sweeps(sweeps, procedure, rig.description)
    if figures:
        render_figures(result)
    if publish_bundle:
        result.bundle_path = publish_spectral(result, data=data, allow_failed=allow_failed)
    return result


def render_figures(result: SpectralCalibration) -> None:
    """Render the calibration's plots into ``result.figures`` (PNG bytes by name)."""
    from sassi_bench.plots.png import figure_png
    from sassi_bench.plots.spectral import spectral_figures

    result.figures = {name: figure_png(fig) for name, fig in spectral_figures(result).items()}


def quality_section(result: SpectralCalibration) -> dict[str, Any]:
    """The ``quality`` section of the bundle manifest (checks named ``spectral.<check>``)."""
    disp = result.dispersion
    return {
        "checks": stage_checks("spectral", result.checks),
        "residuals": {
            "correspondence_rms_px": {
                f"{d.wavelength_nm:g}": d.residual_rms_px for d in result.lasers
            },
            "valid_fraction": {f"{d.wavelength_nm:g}": d.valid_fraction for d in result.lasers},
            "decode_counts": {f"{d.wavelength_nm:g}": d.counts for d in result.lasers},
            "dispersion_residual_px": {f"{k:g}": v for k, v in disp.residual_px.items()},
            "position_sigma_px": disp.position_sigma_px,
            "blur_measured_sigma_px": dict(
                zip(
                    [f"{x:g}" for x in result.blur.wavelengths_nm],
                    result.blur.measured_sigma_px.tolist(),
                    strict=True,
                )
            ),
        },
        "leave_one_out": {f"{k:g}": v for k, v in disp.leave_one_out.items()},
        "laser_lines": {
            f"{label:g}": {
                "label_nm": line.label_nm,
                "estimated_nm": line.estimated_nm if np.isfinite(line.estimated_nm) else None,
                "fitted_nm": disp.wavelengths_nm.get(label, label),
                "from_lines_nm": list(line.from_lines),
                "off_label": line.off_label,
            }
            for label, line in result.laser_lines.items()
        },
        "notes": laser_line_notes(result),
    }


def publish_spectral(result: SpectralCalibration, *, data=None, allow_failed: bool = False) -> Path:
    """Publish the spectral calibration as a bundle (plots go under ``report/``)."""
    return publish(
        result.models(),
        rig=result.rig_description,
        quality=quality_section(result),
        procedure={k: v for k, v in result.procedure.items() if k != "source"},
        inputs=[{"id": s.id, "sha256": s.sha256(), "kind": "session"} for s in result.sessions],
        reports={f"{name}.png": png for name, png in result.figures.items()},
        allow_failed=allow_failed,
        data=data,
    )
