"""The calibration health check's reduction: does a bundle still hold on the bench?

A health check's lamp frames (:mod:`~sassi_bench.workflows.health_check` captures them)
are compared with where the bundle puts the lamp's lines
(:mod:`sassi_bench.calibrate.streak_shift`): the shift of every pinhole's streak along
the dispersion, a smooth map of it over the field, the wavelength error it implies, and
the row shift across the dispersion. Each bundle part gets a verdict; the guide camera's
homography is not seen by these frames and is said so.
"""

from __future__ import annotations

import hashlib
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sassi_bench.acquire.plan_geometry import planned_health_check
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import LAMP_PINHOLE_PITCH_PX
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.calibrate.lamp_streaks import signal_and_variance
from sassi_bench.calibrate.streak_shift import (
    ShiftMap,
    StreakShifts,
    measure_streak_shifts,
    row_shifts,
    shift_field_map,
)
from sassi_bench.provenance import package_version
from sassi_bench.reduce.health_budget import ShiftFrameRecord
from sassi_bench.reduce.lamps import camera_noise, lamp_frame_steps, lamp_streaks
from sassi_bench.rig.config import RigDescription

__all__ = ["GUIDE_NOT_TESTED", "HealthCheck", "check_session", "health_lamps"]

GUIDE_NOT_TESTED = "not tested by this check (the guide camera does not see the streaks)"


@dataclass(frozen=True, eq=False)
class HealthCheck:
    """One health check of a bundle on its rig.

    Attributes
    ----------
    rig, rig_sha256
        The rig checked and its description's hash.
    bundle_version, bundle_sha256
        The bundle checked and the hash of its manifest.
    checked_utc
        When (ISO 8601, UTC).
    light, frames, pinholes
        The lamp, the frames captured, the pinholes measured.
    capture_s, processing_s
        Wall-clock time of the capture and of the measurement.
    shifts, field
        Per-pinhole shifts and their map over the field.
    row_mean_px, row_max_px
        Mean and largest shift across the dispersion.
    parts
        Verdict per bundle part (``"holds"``, ``"recalibrate spectral"`` or why it was not
        tested).
    tolerances
        The procedure's tolerances.
    session_id
        The session holding the frames.
    notes
        Lines the summary prints after the verdicts.
    frame_record
        What the check took and why (:mod:`~sassi_bench.reduce.health_budget`).
    """

    rig: str
    rig_sha256: str
    bundle_version: str
    bundle_sha256: str
    checked_utc: str
    light: str
    frames: int
    pinholes: int
    capture_s: float
    processing_s: float
    shifts: StreakShifts
    field: ShiftMap
    row_mean_px: float
    row_max_px: float
    parts: dict[str, str]
    tolerances: dict[str, float]
    session_id: str = ""
    notes: list[str] = field(default_factory=list)
    frame_record: ShiftFrameRecord | None = None

    @property
    def holds(self) -> bool:
        """Whether every part the check tests still holds."""
        return all(v != "recalibrate spectral" for v in self.parts.values())

    @property
    def verdict(self) -> str:
        """``"holds"`` or ``"recalibrate"``."""
        return "holds" if self.holds else "recalibrate"

    def figures(self) -> dict[str, float]:
        """The numbers a history row keeps."""
        return {
            "shift_x_mean_px": self.field.mean_px,
            "shift_x_max_px": self.field.max_px,
            "shift_y_mean_px": self.row_mean_px,
            "shift_y_max_px": self.row_max_px,
            "wavelength_rms_nm": self.field.wavelength_rms_nm,
            "wavelength_max_nm": self.field.wavelength_max_nm,
        }

    def record(self) -> dict[str, Any]:
        """The check as a history row
        (:class:`~sassi_bench.storage.health_history.HealthHistory`)."""
        return {
            "checked_utc": self.checked_utc,
            "rig": self.rig,
            "rig_sha256": self.rig_sha256,
            "bundle_version": self.bundle_version,
            "bundle_sha256": self.bundle_sha256,
            "light": self.light,
            "frames": self.frames,
            "pinholes": self.pinholes,
            "capture_s": self.capture_s,
            "processing_s": self.processing_s,
            **self.figures(),
            "tolerance_px": self.tolerances["shift_max_px"],
            "tolerance_nm": self.tolerances["wavelength_max_nm"],
            "verdict": self.verdict,
            "parts_json": dict(self.parts),
            "map_json": {
                "u": self.field.u.tolist(),
                "v": self.field.v.tolist(),
                "dx_px": self.field.dx.tolist(),
            },
            "software": package_version(),
            "session_id": self.session_id,
        }

    def summary(self) -> str:
        """What the command prints."""
        f, tol = self.field, self.tolerances
        lines = [
            f"health check of {self.rig} bundle {self.bundle_version} under {self.light} "
            f"({self.frames} frames, {self.pinholes} pinholes)",
            f"  streak shift along the dispersion: mean {f.mean_px:+.3f} px, max {f.max_px:.3f} px"
            f" +-{f.sigma_px:.3f} px (tolerance {tol['shift_max_px']:g} px)",
            f"  implied wavelength error: {f.wavelength_rms_nm:.3f} nm RMS, "
            f"{f.wavelength_max_nm:.3f} nm max (tolerance {tol['wavelength_max_nm']:g} nm)",
            f"  shift across the dispersion: mean {self.row_mean_px:+.3f} px, max "
            f"{self.row_max_px:.3f} px (tolerance {tol['row_shift_max_px']:g} px)",
            "  shift map (camera px; SLM corners):",
            *("    " + row for row in _map_rows(f)),
        ]
        lines += [f"  {part}: {verdict}" for part, verdict in self.parts.items()]
        lines += [f"  note: {n}" for n in self.notes]
        lines.append(
            f"  verdict: {self.verdict} (capture {self.capture_s:.1f} s, processing "
            f"{self.processing_s:.1f} s)"
        )
        return "\n".join(lines)


def _map_rows(field_map: ShiftMap) -> list[str]:
    """The map on a 5 x 3 grid of the field, as text."""
    u_levels, v_levels = np.unique(field_map.u), np.unique(field_map.v)
    cols = u_levels[np.linspace(0, u_levels.size - 1, 5).round().astype(int)]
    rows = v_levels[np.linspace(0, v_levels.size - 1, 3).round().astype(int)]
    out = []
    for v in rows:
        cells = [field_map.dx[(field_map.u == u) & (field_map.v == v)][0] for u in cols]
        out.append(f"v={v:5.0f}: " + " ".join(f"{c:+.3f}" for c in cells))
    return out


def health_lamps(
    procedure: Mapping[str, Any], desc: RigDescription | None = None
) -> dict[str, Any]:
    """The lamp-frame settings of a health check (as the spectral procedure's ``lamps``);
    a pitch the procedure leaves ``null`` is the rig's derived lamp pitch (``desc``).

    Examples
    --------
    >>> health_lamps({"pinhole_pitch_px": [100, 24], "frames": 2})
    {'lamps': {'pinhole_pitch_px': [100, 24], 'frames': 2}}
    """
    if desc is not None:
        procedure = planned_health_check(procedure, desc)
    return {
        "lamps": {
            "pinhole_pitch_px": list(procedure.get("pinhole_pitch_px") or LAMP_PINHOLE_PITCH_PX),
            "frames": int(procedure.get("frames", 1)),
        }
    }


def check_session(
    session: Session,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    desc: RigDescription,
    *,
    light: str,
    checked_utc: str,
    capture_s: float,
    frames: int | None = None,
) -> HealthCheck:
    """Compare a health-check session's lamp streaks with the bundle.

    Parameters
    ----------
    session
        The check's frames (a lamp plan of :func:`health_lamps`).
    bundle
        The bundle checked.
    procedure
        The health-check procedure (field degree, tolerances).
    desc
        The rig's description.
    light, checked_utc, capture_s
        The lamp, when the check was taken and how long its capture took.
    frames
        Use the first ``frames`` pinhole frames and as many closed-SLM frames (None:
        every frame of the plan).

    Returns
    -------
    HealthCheck

    Raises
    ------
    ProcedureError
        No lamp light in the frames (the lamp off).

    Examples
    --------
    Not run here (it needs captured sessions)::

        check = check_session(session, bundle, proc, desc, light="lamp:HgAr",
                              checked_utc="2026-11-22T08:00:00+00:00", capture_s=1.2)
    """
    started = time.perf_counter()
    lamp_proc = health_lamps(procedure, desc)
    models = bundle.models
    (streaks,) = lamp_streaks(session, lamp_proc, desc, models.dispersion, models.blur, frames)
    plan = session.plan
    used = lamp_frame_steps(plan, frames)
    signal, _ = signal_and_variance(
        session.read_frames(lamp_frame_steps(plan, frames, role="lamp-pinholes")),
        session.read_frames(lamp_frame_steps(plan, frames, role="lamp-blank")),
        **camera_noise(desc),
    )
    dy = row_shifts(signal, streaks.profiles, models.dispersion, streaks.lines_nm)
    shifts = measure_streak_shifts(
        streaks.profiles,
        models.dispersion,
        streaks.lines_nm,
        streaks.start_intensity,
        streaks.psf_sigma_px,
        streaks.aperture_px,
        dy=dy,
        spot=streaks.spot,
    )
    field_map = shift_field_map(shifts, models.dispersion, degree=int(procedure["field_degree"]))
    tol = {k: float(v) for k, v in procedure["tolerances"].items()}
    row_mean, row_max = field_map.row_mean_px, field_map.row_max_px
    columns_hold = (
        field_map.max_px <= tol["shift_max_px"]
        and field_map.wavelength_max_nm <= tol["wavelength_max_nm"]
    )
    parts = {
        "dispersion (columns)": "holds" if columns_hold else "recalibrate spectral",
        "dispersion (rows)": "holds"
        if row_max <= tol["row_shift_max_px"]
        else "recalibrate spectral",
        "guide homography": GUIDE_NOT_TESTED,
        "response": "not tested by this check (lamp lines only)",
    }
    processed = time.perf_counter()
    manifest_file = bundle.path / "manifest.json"
    bundle_hash = (
        hashlib.sha256(manifest_file.read_bytes()).hexdigest() if manifest_file.exists() else ""
    )
    return HealthCheck(
        rig=desc.name,
        rig_sha256=desc.sha256(),
        bundle_version=bundle.version,
        bundle_sha256=bundle_hash,
        checked_utc=checked_utc,
        light=light,
        frames=len(used),
        pinholes=streaks.profiles.count,
        capture_s=capture_s,
        processing_s=processed - started,
        shifts=shifts,
        field=field_map,
        row_mean_px=row_mean,
        row_max_px=row_max,
        parts=parts,
        tolerances=tol,
        session_id=session.id,
    )
