"""The spectral calibration: laser sweeps -> dispersion and blur -> bundle, as named steps.

:data:`STEPS` lists the procedure's steps in order (:func:`run_spectral_calibration`
runs them, the notebooks one at a time): ``open`` checks the procedure against the rig
and opens the sessions of an earlier run; ``exposures`` finds each laser's exposure;
``grey`` measures the SLM's grey-level response (structured sweeps); ``sweep`` records
the sweep plan of :mod:`~sassi_bench.acquire.spectral_plans`, decoded as its frames are
stored; ``blur`` adds pinhole frames until a field blur's stated widths meet their
tolerance; ``lamps`` records the lamp frames on a rig with wavelength lamps, in batches
until every laser is measured within its tolerance or the budget is spent, and
``lamp_field`` the lamp field frames of a field blur's lines past the lasers' band, in
batches until its widths meet their tolerance there too; ``analyse``
fits the dispersion and blur and grades them (:mod:`~sassi_bench.reduce.spectral`);
``figures`` renders the plots and ``publish`` publishes the bundle
(:mod:`~sassi_bench.reduce.spectral_bundle`). Named sessions resume where they stopped;
a resumed session must have been captured with the same capture settings.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.frame_feed import FrameFeed
from sassi_bench.acquire.plan_geometry import planned_spectral
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import (
    blur_lamp_lines,
    blur_pinholes,
    blur_plan,
    check_lamp_pitch,
    grey_plan,
    lamp_pinholes,
    lamp_plan,
    sweep_plan,
)
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.calibrate.grey_response import GreyResponse, sinusoid_profile
from sassi_bench.errors import ConfigError, DeviceError, step_error
from sassi_bench.paths import data_root
from sassi_bench.reduce.blur_budget import (
    BlurFrameRecord,
    LampFieldFrameRecord,
    blur_frame_settings,
    decide_blur_frames,
)
from sassi_bench.reduce.blur_frames import BlurMeasurement
from sassi_bench.reduce.lamp_budget import LampFrameRecord, decide_lamp_frames, lamp_frame_settings
from sassi_bench.reduce.lamps import LampMeasurement, lamp_frame_steps
from sassi_bench.reduce.spectral import (
    SpectralCalibration,
    SpectralSweeps,
    analyse_spectral_sweeps,
    lamp_measurement,
)
from sassi_bench.reduce.spectral_bundle import publish_spectral, render_figures
from sassi_bench.reduce.sweep_stream import DecodedSweep, SweepStream
from sassi_bench.reduce.sweeps import analyse_sweep, blur_form, measure_response
from sassi_bench.rig.lights import laser_light
from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.steps import run_steps

__all__ = [
    "CAPTURE_STEPS",
    "STEPS",
    "SpectralRun",
    "capture_blur_frames",
    "capture_lamp_field_frames",
    "capture_lamp_frames",
    "capture_spectral_sweeps",
    "open_lamp_session",
    "procedure_lasers",
    "run_spectral_calibration",
]


def _session_id(base: str | None) -> str:
    if base:
        return base
    return "spectral-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")


def procedure_lasers(procedure: Mapping[str, Any], lasers_nm: Sequence[float]) -> list[float]:
    """The laser lines a spectral calibration sweeps: the procedure's ``lasers_nm`` when it
    pins them, else every laser of the rig.

    Parameters
    ----------
    procedure
        The spectral-calibration procedure (its ``lasers_nm`` may be None).
    lasers_nm
        The rig's laser lines, from its description.

    Returns
    -------
    list of float
        Wavelengths, nm.

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


def _resume(session_id: str, data: str | os.PathLike[str] | None) -> Session | None:
    """The existing session of this id, or None if there is none (damage is an error)."""
    if not (data_root(data) / "sessions" / session_id).exists():
        return None
    return Session.open(session_id, data=data)


def _capture_settings(proc: Mapping[str, Any]) -> dict[str, Any]:
    """The parts of a procedure that decide what is captured, as JSON values (so 450 and
    450.0 nm are the same laser). Fit settings and tolerances may change between capture
    and analysis (a person excluding a region in the notebook); these may not."""
    # window_sigmas is a fit setting; max_frames bounds the blur step's own session
    fit_only = ("window_sigmas", "max_frames")
    blur = {k: v for k, v in thaw(proc.get("blur", {})).items() if k not in fit_only}
    settings = {k: thaw(proc.get(k)) for k in ("lasers_nm", "sweep", "exposure")}
    return json.loads(json.dumps({**settings, "blur": blur}))


def _check_same_procedure(
    session: Session, proc: Mapping[str, Any], rig_lasers: Sequence[float]
) -> None:
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


@dataclass
class SpectralRun:
    """The state of a spectral calibration as its steps run.

    Attributes
    ----------
    rig, procedure
        The devices and the procedure.
    base, data, progress, allow_failed
        The sessions' base id, the data root, progress bars, and whether a bundle that
        failed a check is published (marked).
    lasers, extra
        The lines swept, and those with pinhole (blur) frames only.
    grey, sweep, lamps
        The sessions (None until opened or created; ``lamps`` None on a rig without
        wavelength lamps).
    exposures
        Exposure (s) per swept line, measured for a new sweep session.
    response
        The SLM's grey-level response (structured sweeps).
    decoded
        The sweep decoded as its frames were stored.
    result
        The analysed calibration (its ``figures`` and ``bundle_path`` once made).
    lamp_record, lamp_measurement
        What the lamp step took and why, and what it measured with.
    blur, blur_record, blur_measurement
        The blur step's session of added pinhole frames (None when the sweep's were
        enough), what the step took and why (None for a blur form stating no
        uncertainty), and what it measured with (a field blur only).
    lamp_field_record
        What the lamp field step took and why (None without lamp field frames).
    """

    rig: Rig
    procedure: dict[str, Any]
    base: str
    data: str | os.PathLike[str] | None = None
    progress: bool = True
    allow_failed: bool = False
    lasers: list[float] = field(default_factory=list)
    extra: list[float] = field(default_factory=list)
    grey: Session | None = None
    sweep: Session | None = None
    lamps: Session | None = None
    exposures: dict[float, float] = field(default_factory=dict)
    response: GreyResponse | None = None
    decoded: DecodedSweep | None = None
    result: SpectralCalibration | None = None
    lamp_record: LampFrameRecord | None = None
    lamp_measurement: LampMeasurement | None = None
    blur: Session | None = None
    blur_record: BlurFrameRecord | None = None
    blur_measurement: BlurMeasurement | None = None
    lamp_field_record: LampFieldFrameRecord | None = None

    @property
    def saturation(self) -> int:
        """Raw value at which the spectral camera saturates."""
        return 2**self.rig.spectral_camera.bit_depth - 1

    def expose(self, laser: float, pattern: Mapping) -> float:
        """The exposure that fills ``pattern``'s frames under ``laser`` (the procedure's
        ``exposure`` section) on the white diffuser."""
        exp_cfg = self.procedure.get("exposure", {})
        self.rig.set_scene("white")
        return auto_exposure(
            self.rig,
            laser_light(laser),
            pattern,
            target_fraction=float(exp_cfg.get("target_fraction", 0.6)),
            start_s=float(exp_cfg.get("start_s", 0.01)),
            max_s=float(exp_cfg.get("max_s", 2.0)),
        )

    def sweeps(self) -> SpectralSweeps:
        """The sessions captured so far and what was measured from them."""
        return SpectralSweeps(
            self.grey, self.sweep, self.lamps, self.response, self.decoded,
            self.lamp_record, self.lamp_measurement, self.blur, self.blur_record,
            self.lamp_field_record,
        )  # fmt: skip


def open_sessions(run: SpectralRun) -> None:
    """Check the procedure against the rig (lasers, lamp pinhole pitch) and open the
    grey-level and sweep sessions of an earlier run, refusing other capture settings."""
    proc = run.procedure
    run.lasers = procedure_lasers(proc, run.rig.description.lasers_nm)
    run.extra = [float(x) for x in proc["blur"].get("extra_lasers_nm", [])]
    _check_lasers(run.rig, run.lasers + run.extra)
    check_lamp_pitch(run.rig.description, proc)
    run.grey = _resume(f"{run.base}-grey", run.data)
    run.sweep = _resume(f"{run.base}-sweep", run.data)
    for existing in (run.grey, run.sweep):
        if existing is not None:
            _check_same_procedure(existing, proc, run.rig.description.lasers_nm)


def measure_exposures(run: SpectralRun) -> None:
    """Each swept line's exposure on the open SLM (for a sweep session still to plan)."""
    if run.sweep is None:
        run.exposures = {laser: run.expose(laser, {"kind": "full"}) for laser in run.lasers}


def capture_grey(run: SpectralRun) -> None:
    """The grey-level session (structured sweeps): uniform grey levels under the middle
    line; the SLM's grey-level response measured from it."""
    if run.procedure["sweep"]["mode"] == "structured":
        middle = run.lasers[len(run.lasers) // 2]
        if run.grey is None:
            exposure = run.exposures.get(middle) or run.expose(middle, {"kind": "full"})
            plan = grey_plan(run.procedure, middle, exposure)
            run.grey = Session.create(
                run.rig.description, plan, session_id=f"{run.base}-grey", data=run.data
            )
        run_plan(run.rig, run.grey.plan, run.grey, progress=run.progress)
    if run.grey is not None:
        run.response = measure_response(run.grey, run.saturation)


def capture_sweep(run: SpectralRun) -> None:
    """The sweep session (planned with the sinusoids precompensated for the grey-level
    response), decoded as its frames are stored (those stored before are read back)."""
    proc, rig = run.procedure, run.rig
    if run.sweep is None:
        pinholes = blur_pinholes(proc["blur"]["pinhole_pitch_px"], rig.slm.shape)
        blur_exposures = {laser: run.expose(laser, pinholes) for laser in run.lasers + run.extra}
        period = int(proc["sweep"]["phase_period_px"])
        profile = (
            sinusoid_profile(period, run.response).tolist() if run.response is not None else None
        )
        plan = sweep_plan(proc, rig.slm.shape, run.exposures, profile, blur_exposures)
        run.sweep = Session.create(
            rig.description, plan, session_id=f"{run.base}-sweep", data=run.data
        )
    stream = SweepStream(run.sweep.plan, proc, rig.slm.shape, run.saturation)
    with FrameFeed(run.sweep, stream.steps, stream.add, label="sweep") as feed:
        run_plan(rig, run.sweep.plan, feed.tee(), progress=run.progress)
        feed.finish()
    run.decoded = stream.result()


def capture_blur(run: SpectralRun) -> None:
    """More pinhole frames of every laser, on a field blur, in batches until its stated
    width 1-sigma meets the tolerance or the budget is spent
    (:func:`capture_blur_frames`)."""
    desc = run.rig.description
    if blur_form(run.procedure, desc) != "field_covariance":
        return
    lasers = analyse_sweep(run.sweep, run.procedure, run.rig.slm.shape, run.saturation, run.decoded)
    fit = run.procedure.get("fit") or {}
    measurement = BlurMeasurement(
        run.sweep, run.procedure, desc, [d.laser_map for d in lasers],
        run.decoded.pinholes if run.decoded is not None else None,
        field_degree=int(fit.get("field_degree", 5)), order=int(fit.get("dispersion_order", 2)),
    )  # fmt: skip
    run.blur, run.blur_record = capture_blur_frames(
        run.rig, run.sweep, run.procedure, measurement, f"{run.base}-blur",
        data=run.data, progress=run.progress,
    )  # fmt: skip
    run.blur_measurement = measurement


def capture_lamps(run: SpectralRun) -> None:
    """The lamp frames, on a rig with wavelength lamps, taken in batches until every
    laser is measured within the tolerance or the budget is spent
    (:func:`capture_lamp_frames`)."""
    run.lamps = open_lamp_session(run.rig, run.procedure, f"{run.base}-lamps", data=run.data)
    if run.lamps is None:
        return
    run.lamp_measurement = lamp_measurement(run.sweeps(), run.procedure, run.rig.description)
    run.lamp_record = capture_lamp_frames(
        run.rig, run.lamps, run.procedure, run.lamp_measurement.sigma_nm, progress=run.progress
    )


def capture_lamp_field(run: SpectralRun) -> None:
    """The lamp field frames of a field blur's lines past the lasers' band, taken in
    batches until the field blur's stated widths meet the tolerance over the whole band
    or the lamp budget is spent (:func:`capture_lamp_field_frames`)."""
    measurement = run.blur_measurement
    if run.lamps is None or measurement is None:
        return

    def sigma_px(lamps: Session, frames: int) -> float | None:
        return measurement.fit(run.blur, None, lamps, frames).width_sigma_px

    run.lamp_field_record = capture_lamp_field_frames(
        run.rig, run.lamps, run.procedure, sigma_px, progress=run.progress
    )


def analyse(run: SpectralRun) -> None:
    """Fit the dispersion and blur models to the sessions and grade them."""
    run.result = analyse_spectral_sweeps(run.sweeps(), run.procedure, run.rig.description)


def figures(run: SpectralRun) -> None:
    """The report's plots (kept in the bundle's ``report/``)."""
    render_figures(run.result)


def publish(run: SpectralRun) -> None:
    """Publish the calibration as a bundle (refused when a check failed, unless
    ``allow_failed``)."""
    run.result.bundle_path = publish_spectral(
        run.result, data=run.data, allow_failed=run.allow_failed
    )


#: The spectral calibration's steps, in order.
STEPS = {
    "open": open_sessions,
    "exposures": measure_exposures,
    "grey": capture_grey,
    "sweep": capture_sweep,
    "blur": capture_blur,
    "lamps": capture_lamps,
    "lamp_field": capture_lamp_field,
    "analyse": analyse,
    "figures": figures,
    "publish": publish,
}
#: The steps that capture (and decode as they capture).
CAPTURE_STEPS = ("open", "exposures", "grey", "sweep", "blur", "lamps", "lamp_field")


@drives_rig("spectral calibration")
def capture_spectral_sweeps(
    rig: Rig,
    procedure: Mapping[str, Any],
    *,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> SpectralSweeps:
    """Capture (or resume) the laser sweeps of a spectral calibration: its
    :data:`CAPTURE_STEPS`.

    Parameters
    ----------
    rig
        Device handles (virtual or real).
    procedure
        A validated spectral-calibration procedure
        (:func:`~sassi_bench.procedure.load_procedure`).
    session_id
        Base id of the raw sessions (``<id>-grey``, ``<id>-sweep`` and, on a rig with
        wavelength lamps, ``<id>-lamps``); an existing id resumes its capture (the stored
        plans are reused, not rebuilt).
    data
        Data root for sessions.
    progress
        Show a progress bar per session.

    Returns
    -------
    SpectralSweeps
        The sessions, the grey-level response and the sweep decoded as it was captured
        (:mod:`~sassi_bench.reduce.sweep_stream`; the frames of a resumed session
        stored before are read back in turn, so the decode is the same).

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        sweeps = capture_spectral_sweeps(rig, proc, session_id="lab-2026-11-22")
    """
    proc = planned_spectral(procedure, rig.description)
    run = SpectralRun(rig, proc, _session_id(session_id), data, progress)
    return run_steps(STEPS, run, CAPTURE_STEPS, procedure="spectral calibration").sweeps()


@drives_rig("spectral calibration")
def run_spectral_calibration(
    rig: Rig,
    procedure: Mapping[str, Any],
    *,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
    publish_bundle: bool = True,
    allow_failed: bool = False,
) -> SpectralCalibration:
    """Run the spectral calibration end to end: capture, analyse, plot, publish.

    Parameters
    ----------
    rig, procedure, session_id, data, progress
        As for :func:`capture_spectral_sweeps`.
    publish_bundle, allow_failed
        Publish a bundle (the ``publish`` step); refuse one that failed its checks unless
        ``allow_failed``.

    Returns
    -------
    SpectralCalibration

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        result = run_spectral_calibration(open_rig("sim"), proc)
        result.bundle_path
        # PosixPath('calib_data/sim/v0001')
    """
    steps = [name for name in STEPS if publish_bundle or name != "publish"]
    proc = planned_spectral(procedure, rig.description)
    run = SpectralRun(rig, proc, _session_id(session_id), data, progress, allow_failed)
    return run_steps(STEPS, run, steps, procedure="spectral calibration").result


def _lamp_settings(procedure: Mapping[str, Any]) -> dict[str, Any]:
    return json.loads(json.dumps(thaw(procedure.get("lamps") or {})))


def open_lamp_session(
    rig: Rig,
    procedure: Mapping[str, Any],
    session_id: str,
    *,
    data: str | os.PathLike[str] | None = None,
) -> Session | None:
    """Open (or create) the lamp session of a spectral calibration, planned to its budget.

    A new session measures each lamp's exposure and plans ``lamps.max_frames`` closed and
    pinhole frames per lamp (:func:`~sassi_bench.acquire.spectral_plans.lamp_plan`);
    :func:`capture_lamp_frames` captures as many as the lamps need.

    Parameters
    ----------
    rig
        Device handles; a rig without ``wavelength_lamps`` has no lamp session.
    procedure
        The spectral-calibration procedure (its ``lamps`` section).
    session_id
        The session's id (an existing one resumes).
    data
        Data root.

    Returns
    -------
    Session or None
        None when the rig has no lamps.

    Raises
    ------
    ConfigError
        When an existing session was captured with other lamp settings, or the pitch
        lets streaks overlap.
    DeviceError
        When a lamp gives no light at the longest exposure allowed.

    Examples
    --------
    Not run here (it drives a bench)::

        session = open_lamp_session(rig, proc, "lab-2026-11-22-lamps")
    """
    desc = rig.description
    if not desc.wavelength_lamps:
        return None
    if (data_root(data) / "sessions" / session_id).exists():
        session = Session.open(session_id, data=data)
        stored = session.plan.parameters.get("procedure") or {}
        if _lamp_settings(stored) != _lamp_settings(procedure):
            raise ConfigError(
                step_error(
                    f"resume session {session.id}",
                    "its lamp frames were captured with other lamps settings than the "
                    "procedure given now",
                    "resume with the same procedure file, or start a new --session",
                )
            )
        return session
    check_lamp_pitch(desc, procedure)
    settings = procedure.get("lamps") or {}
    pattern = lamp_pinholes(procedure)
    exposures = {}
    for lines in desc.lamp_lines().values():
        rig.set_scene("white")
        try:
            exposures[lines.light] = auto_exposure(
                rig,
                lines.light,
                pattern,
                target_fraction=float(settings.get("target_fraction", 0.6)),
                start_s=float(settings.get("start_s", 0.05)),
                max_s=float(settings.get("max_s", 10.0)),
            )
        except DeviceError as exc:
            raise DeviceError(
                step_error(
                    f"lamp frames {lines.light}",
                    "the lamp's pinholes give no light at the longest exposure allowed "
                    f"({settings.get('max_s', 10.0):g} s)",
                    "switch the lamp on, let it warm up and check that it lights the "
                    "diffuser, or raise lamps.max_s",
                )
            ) from exc
    budget = lamp_frame_settings(procedure)[1]
    field_lamps = []
    if blur_form(procedure, desc) == "field_covariance":  # measured past the lasers' band
        lasers = procedure_lasers(procedure, desc.lasers_nm)
        field_lamps = [
            lines.light
            for lines in desc.lamp_lines().values()
            if blur_lamp_lines(lines, lasers, desc).size
        ]
    slm_shape = (desc.slm.height, desc.slm.width)
    plan = lamp_plan(procedure, exposures, budget, field_lamps, slm_shape)
    return Session.create(desc, plan, session_id=session_id, data=data)


def capture_lamp_frames(
    rig: Rig,
    session: Session,
    procedure: Mapping[str, Any],
    measure: Callable[[Session, int], Mapping[float, float]] | None = None,
    *,
    progress: bool = True,
) -> LampFrameRecord | None:
    """Capture (or resume) lamp frames until every laser is measured within the tolerance.

    Every lamp's first ``lamps.frames`` frames are taken; then, after each batch,
    ``measure`` states every laser's 1-sigma from the frames so far and
    :func:`~sassi_bench.reduce.lamp_budget.decide_lamp_frames` says whether to stop
    (``tolerances.laser_wavelength_sigma_nm`` met, or the session's planned budget,
    ``lamps.max_frames``, spent) or how many frames to have next. The decisions depend on
    the stored frames alone, so a resumed session replays them on the frames it holds
    and captures only the missing ones.

    Parameters
    ----------
    rig
        Device handles.
    session
        The lamp session (:func:`open_lamp_session`).
    procedure
        The spectral-calibration procedure.
    measure
        Every laser's 1-sigma (nm, by label) from a session's first ``n`` frames of every
        lamp (:meth:`~sassi_bench.reduce.lamps.LampMeasurement.sigma_nm`); None captures
        the first ``lamps.frames`` frames and decides nothing.
    progress
        Show a progress bar.

    Returns
    -------
    LampFrameRecord or None
        What was taken and why (None without ``measure``).

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        record = capture_lamp_frames(rig, session, proc, measurement.sigma_nm)
        record.outcome, record.frames
        # ('tolerance met', 4)
    """
    first, budget, tolerance = lamp_frame_settings(procedure)
    planned = 1 + max(int(step.tags.get("frame", 0)) for step in session.plan.steps)
    budget = min(budget, planned)
    frames = min(first, budget)
    batches = []
    while True:
        steps = sorted(
            lamp_frame_steps(session.plan, frames, role="lamp-blank")
            + lamp_frame_steps(session.plan, frames, role="lamp-pinholes")
        )
        run_plan(rig, session.plan, session, progress=progress, steps=steps)
        if measure is None:
            return None
        batch = decide_lamp_frames(frames, measure(session, frames), tolerance, budget, batches)
        batches.append(batch)
        if batch.next_frames is None:
            break
        frames = batch.next_frames
    settings = procedure.get("lamps") or {}
    exposures = session.plan.parameters.get("exposures_s", {})
    return LampFrameRecord(
        tuple(batches),
        tolerance,
        budget,
        {k: float(v) for k, v in exposures.items()},
        float(settings.get("max_s", 10.0)),
    )


def capture_lamp_field_frames(
    rig: Rig,
    session: Session,
    procedure: Mapping[str, Any],
    measure: Callable[[Session, int], float | None],
    *,
    progress: bool = True,
) -> LampFieldFrameRecord | None:
    """Capture (or resume) the lamp field frames until the field blur's stated width
    1-sigma meets the tolerance.

    A field blur measured past the lasers' band leans there on one or two lamp lines,
    dim beside the lasers, whose spot widths are photon-limited. Every offset's first
    ``lamps.frames`` frames are taken; then, after each batch, ``measure`` states the
    field blur's worst 1-sigma with the lamp spots so far, and
    :func:`~sassi_bench.reduce.blur_budget.decide_blur_frames` says whether to stop
    (``tolerances.blur_width_sigma_px`` met, or the lamp budget ``lamps.max_frames``
    spent) or how many frames per offset to have next. The decisions depend on the
    stored frames alone, so a resumed session replays them and captures only the
    missing ones.

    Parameters
    ----------
    rig
        Device handles.
    session
        The lamp session (:func:`open_lamp_session`).
    procedure
        The spectral-calibration procedure.
    measure
        The field blur's stated worst width 1-sigma (camera px) with the lamp spots of a
        session's first ``n`` field frames per offset
        (:meth:`~sassi_bench.reduce.blur_frames.BlurMeasurement.fit`); None: unstated.
    progress
        Show a progress bar.

    Returns
    -------
    LampFieldFrameRecord or None
        What was taken and why; None when the session has no field frames or the fit
        states no uncertainty.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        record = capture_lamp_field_frames(rig, lamps, proc, sigma_px)
        record.outcome, record.frames
        # ('tolerance met', 10)
    """
    plan = session.plan
    field = plan.select(role="lamp-field")
    if not field:
        return None
    first, budget, _ = lamp_frame_settings(procedure)
    tolerance = blur_frame_settings(procedure)[2]
    budget = min(budget, 1 + max(int(plan.steps[i].tags["frame"]) for i in field))
    frames, batches = min(first, budget), []
    while True:
        steps = lamp_frame_steps(plan, frames, role="lamp-field")
        run_plan(rig, plan, session, progress=progress, steps=steps)
        sigma = measure(session, frames)
        if sigma is None:  # the fit states no uncertainty: nothing to decide from
            return None
        batch = decide_blur_frames(frames, sigma, tolerance, budget, batches)
        batches.append(batch)
        if batch.next_frames is None:
            break
        frames = batch.next_frames
    return LampFieldFrameRecord(tuple(batches), tolerance, budget)


def capture_blur_frames(
    rig: Rig,
    sweep: Session,
    procedure: Mapping[str, Any],
    measurement: BlurMeasurement,
    session_id: str,
    *,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> tuple[Session | None, BlurFrameRecord | None]:
    """Add pinhole frames of every laser until the field blur's stated width 1-sigma meets
    the tolerance.

    The sweep's ``blur.frames`` are measured first; then, after each batch,
    :func:`~sassi_bench.reduce.blur_budget.decide_blur_frames` says whether to stop
    (``tolerances.blur_width_sigma_px`` met, or ``blur.max_frames`` spent) or how many
    frames per laser to have next. The added frames go to a session planned to the budget
    (:func:`~sassi_bench.acquire.spectral_plans.blur_plan`), made when the first batch
    asks for more; the decisions depend on the stored frames alone, so a resumed session
    replays them and captures only the missing frames.

    Parameters
    ----------
    rig
        Device handles.
    sweep
        The sweep session (its pinhole frames come first).
    procedure
        The planned spectral-calibration procedure.
    measurement
        Fits the blur from a number of frames per laser.
    session_id
        The blur session's id (an existing one resumes).
    data
        Data root.
    progress
        Show a progress bar.

    Returns
    -------
    tuple
        The blur session (None when the sweep's frames were enough) and what was taken
        and why (None when the fit states no uncertainty).

    Raises
    ------
    ConfigError
        When an existing blur session was planned from another sweep or budget.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        session, record = capture_blur_frames(rig, sweep, proc, measurement, "lab-blur")
        record.outcome, record.frames
        # ('tolerance met', 2)
    """
    first, budget, tolerance = blur_frame_settings(procedure)
    planned = blur_plan(sweep.plan, first, budget)
    session = _resume(session_id, data)
    if session is not None and session.plan.sha256() != planned.sha256():
        raise ConfigError(
            step_error(
                f"resume session {session.id}",
                "its pinhole frames were planned from another sweep or blur.max_frames than "
                "the procedure given now",
                "resume with the same procedure file, or start a new --session",
            )
        )
    frames, batches = first, []
    while True:
        if frames > first:
            if session is None:
                session = Session.create(rig.description, planned, session_id=session_id, data=data)
            steps = [i for i, s in enumerate(planned.steps) if int(s.tags["frame"]) < frames]
            run_plan(rig, session.plan, session, progress=progress, steps=steps)
        sigma = measurement.fit(session, frames).width_sigma_px
        if sigma is None:  # the fit states no uncertainty: nothing to decide from
            return session, None
        batch = decide_blur_frames(frames, sigma, tolerance, budget, batches)
        batches.append(batch)
        if batch.next_frames is None:
            break
        frames = batch.next_frames
    return session, BlurFrameRecord(tuple(batches), tolerance, budget)
