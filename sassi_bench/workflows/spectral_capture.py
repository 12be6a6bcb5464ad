"""The capture stage of the spectral calibration: laser sweeps into raw sessions.

:func:`capture_spectral_sweeps` finds each laser's exposure, measures the SLM's
grey-level response (structured sweeps), then records the sweep plan of
:mod:`sassi_bench.acquire.spectral_plans` and, on a rig with wavelength lamps, the
lamp frames (:mod:`sassi_bench.workflows.spectral_lamps`). Named sessions resume where they stopped;
a resumed session must have been captured with the same capture settings.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import Any

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.frame_feed import FrameFeed
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import check_lamp_pitch, grey_plan, laser_light, sweep_plan
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.calibrate.grey_response import GreyResponse, sinusoid_profile
from sassi_bench.errors import ConfigError, step_error
from sassi_bench.paths import data_root
from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.spectral_decode import measure_response
from sassi_bench.workflows.spectral_lamps import capture_lamp_frames
from sassi_bench.workflows.sweep_stream import DecodedSweep, SweepStream

__all__ = ["SpectralSweeps", "capture_spectral_sweeps", "procedure_lasers"]


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
    blur = {k: v for k, v in thaw(proc.get("blur", {})).items() if k != "window_sigmas"}
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


@dataclass(frozen=True)
class SpectralSweeps:
    """The raw sessions of a spectral calibration: the grey-level response (structured
    sweeps only), the laser sweep itself and the lamp frames (rigs with lamps only); and
    what was measured from them as they were captured: the grey-level response and the
    sweep's decode (None: the analysis reads them from the sessions)."""

    grey: Session | None
    sweep: Session
    lamps: Session | None = None
    grey_response: GreyResponse | None = None
    decoded: DecodedSweep | None = None

    @property
    def sessions(self) -> list[Session]:
        """The sessions, in capture order."""
        return [s for s in (self.grey, self.sweep, self.lamps) if s is not None]


@drives_rig("spectral calibration")
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
        (:mod:`~sassi_bench.workflows.sweep_stream`; the frames of a resumed session
        stored before are read back in turn, so the decode is the same).

    Examples
    --------
    >>> sweeps = capture_spectral_sweeps(rig, proc, session_id="lab-2026-11-22")  # doctest: +SKIP
    """
    proc = dict(procedure)
    lasers = procedure_lasers(proc, rig.description.lasers_nm)
    extra = [float(x) for x in proc["blur"].get("extra_lasers_nm", [])]
    _check_lasers(rig, lasers + extra)
    check_lamp_pitch(rig.description, proc)
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
    response = measure_response(grey, saturation) if grey is not None else None
    if sweep is None:
        # The sinusoids are precompensated for the SLM's measured grey-level response.
        pitch = [int(p) for p in proc["blur"]["pinhole_pitch_px"]]
        pinholes = {"kind": "pinholes", "pitch": pitch, "offset": [pitch[0] // 2, pitch[1] // 2]}
        blur_exposures = {laser: expose(laser, pinholes) for laser in lasers + extra}
        period = int(proc["sweep"]["phase_period_px"])
        profile = sinusoid_profile(period, response).tolist() if response is not None else None
        plan = sweep_plan(proc, slm_shape, exposures, profile, blur_exposures)
        sweep = Session.create(rig.description, plan, session_id=f"{base}-sweep", data=data)
    # The sweep is decoded as its frames are stored (those stored before are read back).
    stream = SweepStream(sweep.plan, proc, slm_shape, saturation)
    with FrameFeed(sweep, stream.steps, stream.add, label="sweep") as feed:
        run_plan(rig, sweep.plan, feed.tee(), progress=progress)
        feed.finish()
    lamps = capture_lamp_frames(rig, proc, f"{base}-lamps", data=data, progress=progress)
    return SpectralSweeps(grey, sweep, lamps, response, stream.result())
