"""The calibration health check on the bench: capture a few lamp frames, compare them.

A few frames under a wavelength lamp (closed-SLM frames and a sparse pinhole array, as in
the calibration's lamp frames: a second or two on a real bench, at most 20 frames on the
virtual one) are captured and compared with where the bundle puts the lamp's lines
(:func:`~sassi_bench.reduce.health.check_session`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from dataclasses import replace
from datetime import UTC, datetime
from typing import Any

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import lamp_pinholes, lamp_plan
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.errors import ConfigError, step_error
from sassi_bench.reduce.health import HealthCheck, check_session, health_lamps
from sassi_bench.reduce.health_budget import (
    ShiftFrameRecord,
    decide_shift_frames,
    shift_frame_settings,
)
from sassi_bench.reduce.lamps import lamp_frame_steps
from sassi_bench.rig.config import RigDescription, rig_dict_sha256
from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.rig_lock import drives_rig

__all__ = ["check_light", "run_health_check"]


def check_light(desc: RigDescription, procedure: Mapping[str, Any]) -> str:
    """The lamp the check uses: the procedure's, or the rig's first wavelength lamp.

    Raises
    ------
    ConfigError
        When the rig has no wavelength lamps, or not the one asked for.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> check_light(load_rig_description("sim"), {"light": "auto"})
    'lamp:HgAr'
    """
    lamps = {lines.light.lower(): lines.light for lines in desc.lamp_lines().values()}
    if not lamps:
        raise ConfigError(
            step_error(
                "health check",
                f"rig {desc.name!r} has no wavelength_lamps",
                "add a pen-ray lamp to the rig (wavelength_lamps: [HgAr]) and calibrate with it",
            )
        )
    asked = str(procedure.get("light", "auto"))
    if asked == "auto":
        return next(iter(lamps.values()))
    if asked.lower() not in lamps:
        raise ConfigError(
            step_error(
                "health check",
                f"{asked} is not one of the rig's lamps ({', '.join(lamps.values())})",
                "pass --light with one of them",
            )
        )
    return lamps[asked.lower()]


def _check_same_rig(rig: Rig, bundle: CalibrationBundle) -> None:
    desc = rig.description
    if bundle.rig_name != desc.name:
        raise ConfigError(
            step_error(
                "health check",
                f"bundle {bundle.version} calibrates rig {bundle.rig_name!r}, not {desc.name!r}",
                f"pass a bundle of rig {desc.name!r} (--bundle latest picks its latest)",
            )
        )
    # Compared as sessions compare rigs: where the hardware is plugged in (ports, .cti
    # files, the monitor) is left out, so a bench moved to another port is the same rig.
    stored = rig_dict_sha256(thaw(bundle.manifest["rig"])) if "rig" in bundle.manifest else None
    if stored and stored != desc.sha256():
        raise ConfigError(
            step_error(
                "health check",
                f"bundle {bundle.version} was calibrated on another description of rig "
                f"{desc.name!r} (rig hash {stored[:12]}, this rig's is {desc.sha256()[:12]})",
                "check with the rig file the bundle was calibrated with, or recalibrate",
            )
        )


#: The lamp exposure search when the bundle records no exposure for the lamp and the
#: procedure gives none (procedure files older than its ``exposure`` section).
DEFAULT_EXPOSURE = {"target_fraction": 0.6, "max_s": 10.0, "start_s": 0.05}


def _lamp_exposure(bundle: CalibrationBundle, light: str) -> float | None:
    quality = bundle.manifest.get("quality") or {}
    for section in (quality, quality.get("spectral") or {}):
        for entry in (section.get("lamps") or {}).values():
            if isinstance(entry, Mapping) and entry.get("light") == light:
                exposure = entry.get("exposure_s")
                return float(exposure) if exposure else None
    return None


@drives_rig("health check")
def run_health_check(
    rig: Rig,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    data: str | os.PathLike[str] | None = None,
    progress: bool = False,
    session_id: str | None = None,
) -> HealthCheck:
    """Capture the check's frames and compare the lamp streaks with the bundle.

    The check measures until confident: ``frames`` pinhole frames first, then, while the
    shift map's stated 1-sigma is above ``tolerances.shift_sigma_px``, the frames
    :func:`~sassi_bench.reduce.health_budget.decide_shift_frames` asks for, at most
    ``max_frames``; what it took and why is in the check's notes and ``frame_record``.

    Parameters
    ----------
    rig
        The rig (with wavelength lamps).
    bundle
        A bundle of that rig.
    procedure
        The health-check procedure (:func:`~sassi_bench.procedure.load_procedure`
        ``("health_check")``).
    data
        Data root (the frames go into a session ``check-<time>``).
    progress
        Show a progress bar.
    session_id
        The session holding the frames (an existing one resumes; None: ``check-<time>``).

    Returns
    -------
    HealthCheck

    Raises
    ------
    ConfigError
        A bundle of another rig, or a rig without lamps.
    ProcedureError
        No lamp light in the frames (the lamp off).

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        check = run_health_check(rig, load("latest", rig="sim"), load_procedure("health_check"))
        check.verdict
        # 'holds'
    """
    _check_same_rig(rig, bundle)
    light = check_light(rig.description, procedure)
    desc = rig.description
    lamp_proc = health_lamps(procedure, desc)
    started = time.perf_counter()
    exposure = _lamp_exposure(bundle, light)
    if exposure is None:
        rig.set_scene("white")
        search = {**DEFAULT_EXPOSURE, **(procedure.get("exposure") or {})}
        exposure = auto_exposure(
            rig, light, lamp_pinholes(lamp_proc),
            target_fraction=float(search["target_fraction"]), max_s=float(search["max_s"]),
            start_s=float(search["start_s"]),
        )  # fmt: skip
    stamp = datetime.now(UTC)
    first, budget, tolerance = shift_frame_settings(procedure)
    session = Session.resume_or_plan(
        desc, lambda: lamp_plan(lamp_proc, {light: exposure}, frames=budget),
        session_id=session_id or "check-" + stamp.strftime("%Y%m%dT%H%M%S%fZ"), data=data,
    )  # fmt: skip
    planned = 1 + max(int(step.tags.get("frame", 0)) for step in session.plan.steps)
    budget = min(budget, planned)  # a resumed session keeps the budget it was planned to
    rig.set_scene("white")
    frames, batches = min(first, budget), []
    capture_s = time.perf_counter() - started  # the exposure search's
    while True:
        began = time.perf_counter()
        run_plan(rig, session.plan, session, progress=progress,
                 steps=lamp_frame_steps(session.plan, frames))  # fmt: skip
        capture_s += time.perf_counter() - began
        check = check_session(
            session, bundle, procedure, desc, light=light, frames=frames,
            checked_utc=stamp.isoformat(timespec="seconds"), capture_s=capture_s,
        )  # fmt: skip
        batch = decide_shift_frames(
            frames, check.field.sigma_px, check.field.max_px, tolerance, budget, batches
        )  # fmt: skip
        batches.append(batch)
        if batch.next_frames is None:
            break
        frames = batch.next_frames
    record = ShiftFrameRecord(tuple(batches), tolerance, budget)
    return replace(check, notes=[*check.notes, record.note()], frame_record=record)
