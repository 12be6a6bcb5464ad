"""Pinhole scans on a rig: reference cubes and the radiometric response.

:func:`capture_scan` captures what a scan session misses and hands every frame, as soon
as it is stored, to the scan's reading pass (:class:`~sassi_bench.spectra.scan.ScanAssembly`,
on a worker thread of a :class:`~sassi_bench.acquire.frame_feed.FrameFeed`), so that pass
overlaps the capture and no frame is read back; frames stored before (a resumed capture)
are read back first, on a thread per CPU. Only the spectra pass and the deblur wait for
the last frame: they need the background, which every frame adds to. The reading pass's
sums are exact, so the cube is the one :func:`~sassi_bench.reduce.scan.assemble_scan`
makes of the finished session, wherever a capture was interrupted.

:func:`run_scan` scans a scene and assembles the cube with a bundle (divided by its
response when it has one); :func:`run_response` scans a white diffuser under a source of
known spectrum and publishes a new bundle version with the per-bin response
(:mod:`~sassi_bench.reduce.response`).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from sassi_bench._shared.memory import release_memory
from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.frame_feed import FrameFeed
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.plan_geometry import scan_pitch
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import check_pitch, check_roi, refining_scan_plan, scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.streak_pitch import check_scan_pitch
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.derive import check_parent
from sassi_bench.errors import ConfigError, ProcedureError, step_error
from sassi_bench.reduce.response import publish_response, response_source, white_mean
from sassi_bench.reduce.response_budget import (
    ResponseFrameRecord,
    decide_response_frames,
    response_de00_sigma,
    response_frame_settings,
    response_sigma,
)
from sassi_bench.reduce.response_colour import ColourChart
from sassi_bench.reduce.scan import ScanRun, finish_scan, read_stored
from sassi_bench.rig.rig import Rig, check_light, check_scene
from sassi_bench.spectra.scan import ScanAssembly, ScanCube
from sassi_bench.validate.colorimetry import reflectance_to_xyz, white_chromaticity
from sassi_bench.validate.reference import reference_chart
from sassi_bench.workflows.rig_lock import drives_rig

__all__ = [
    "RESPONSE_CHART",
    "capture_scan",
    "check_scan",
    "response_colour_chart",
    "run_response",
    "run_scan",
]

#: The reference ColorChecker the response's colour error is computed on (the Macbeth
#: validation's default).
RESPONSE_CHART = "BabelColor Average"


def _stamp(prefix: str) -> str:
    return f"{prefix}-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")


def check_scan(
    rig: Rig,
    scene: str,
    light: str,
    pitch: tuple[int, int],
    roi: Sequence[int] | None = None,
) -> None:
    """Refuse a scan the rig cannot take (scene, light, pitch, ROI), before any capture.

    Parameters
    ----------
    rig
        Device handles.
    scene
        The scene to scan (a virtual bench's scene name).
    light
        One of the rig's lights.
    pitch
        (horizontal, vertical) pinhole pitch in SLM pixels.
    roi
        Part of the SLM to assemble, or None for all of it.

    Raises
    ------
    ProcedureError
        Naming the first argument the rig cannot take, and the choices it has; or a
        pitch at which the streaks leave no streak-free camera columns
        (:func:`~sassi_bench.acquire.streak_pitch.check_scan_pitch`).

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        check_scan(open_rig("sim"), "colorchecker", "led", (100, 5))
    """
    check_scene(scene, step="scan")
    check_light(light, rig.light.available, step="scan")
    check_pitch(pitch, rig.slm.shape)
    check_scan_pitch(rig.description, pitch)
    check_roi(roi, rig.slm.shape, step="scan")


def capture_scan(
    rig: Rig,
    session: Session,
    bundle: CalibrationBundle,
    *,
    roi: Sequence[int] | None = None,
    deblur: bool = True,
    keep_raw: bool = False,
    unmixing: str = "mixed",
    progress: bool = True,
    frames: int | None = None,
) -> ScanCube:
    """Capture what a scan session misses and assemble the scan as its frames are stored.

    Parameters
    ----------
    rig
        Device handles.
    session
        A pinhole-scan session (:func:`~sassi_bench.acquire.scan_plans.scan_plan`), new or
        partly captured.
    bundle, roi, deblur, keep_raw, unmixing
        As for :func:`~sassi_bench.reduce.scan.assemble_scan`.
    progress
        Show progress bars.
    frames
        Only the first ``frames`` pinhole frames of a refining plan
        (:func:`~sassi_bench.acquire.scan_plans.refining_scan_plan`); None: every frame.

    Returns
    -------
    ScanCube

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        scan = capture_scan(rig, session, bundle, keep_raw=True)
    """
    plan = session.plan if frames is None else _prefix(session.plan, frames)
    assembly = ScanAssembly(
        plan, session.rig, bundle, roi=roi, deblur=deblur, keep_raw=keep_raw, unmixing=unmixing
    )
    stored = session.completed
    read_stored(assembly, session, [i for i in assembly.steps if i in stored], progress=progress)
    todo = [i for i in assembly.steps if i not in stored]
    with FrameFeed(session, todo, assembly.read, label="scan") as feed:
        run_plan(rig, session.plan, feed.tee(), progress=progress, steps=range(len(plan.steps)))
        feed.finish()
    release_memory()  # the reading pass's per-frame buffers, before the cube's work
    return finish_scan(assembly, session, progress=progress)


def _prefix(plan: Plan, frames: int) -> Plan:
    """The closed-SLM frame and the first ``frames`` pinhole frames of a refining plan,
    which come first in it (so a step's index is the session's)."""
    count = 1 + max(
        (i for i, s in enumerate(plan.steps) if int(s.tags.get("frame", -1)) < frames),
        default=-1,
    )
    return Plan(plan.name, plan.steps[:count], plan.parameters)


def _plan(rig: Rig, scene: str, light: str, pitch, every: int, target: float) -> Plan:
    rig.set_scene(scene)
    # One pinhole frame samples every 100th column and can miss the brightest part of
    # the scene (the chart's white patch), which then saturates later in the scan; so
    # expose for the brightest of five frames spread over the column pitch.
    exposure = None
    for dx in range(0, pitch[0], max(1, pitch[0] // 5)):
        pattern = {"kind": "pinholes", "pitch": list(pitch), "offset": [dx, 0]}
        found = auto_exposure(rig, light, pattern, target_fraction=target, start_s=exposure or 0.01)
        exposure = found if exposure is None else min(exposure, found)
    plan = scan_plan(rig.slm.shape, light, exposure, tuple(pitch), scene=scene)
    if every > 1:  # a thinned scan: every n-th pinhole offset
        keep = [s for i, s in enumerate(plan.steps) if s.tags["role"] == "closed" or i % every == 1]
        plan = Plan(plan.name, tuple(keep), {**plan.parameters, "every": every})
    return plan


@drives_rig("radiometric response")
def run_response(
    rig: Rig,
    bundle: CalibrationBundle,
    *,
    light: str = "halogen",
    temperature_k: float | None = None,
    reference_csv: str | os.PathLike[str] | None = None,
    reflectance: float = 1.0,
    pitch: tuple[int, int] | None = None,
    every: int = 25,
    max_frames: int | None = None,
    de00_sigma_max: float | None = None,
    sigma_max: float | None = None,
    session_id: str | None = None,
    data=None,
    progress: bool = True,
    allow_failed: bool = False,
) -> Path:
    """Measure the per-bin response on a white diffuser and publish it in a new bundle.

    The source spectrum is a blackbody at ``temperature_k`` (default: the rig's
    ``light.halogen_k``) or a reference CSV (wavelength_nm, power). The new bundle
    carries ``bundle``'s quality checks; a parent published with an override is refused
    (before anything is captured) unless ``allow_failed``.

    The scan measures until confident: every ``every``-th pinhole offset first, then,
    while the colour error the response's stated noise causes (the mean CIEDE2000
    1-sigma over the ColorChecker's patches) is above ``de00_sigma_max`` (or its worst
    bin's relative 1-sigma above ``sigma_max``, when given), the offsets between them
    (:func:`~sassi_bench.reduce.response_budget.decide_response_frames`), at most
    ``max_frames`` pinhole frames; what was taken and why goes into the bundle
    (``quality.residuals.response.response_frames``).

    Parameters
    ----------
    rig
        Device handles; the white diffuser is put in front.
    bundle
        The bundle the scan is assembled with and the new version derives from.
    light
        The light the diffuser is lit with.
    temperature_k, reference_csv
        The source's spectrum (see :func:`response_source`).
    reflectance
        Reflectance of the diffuser.
    pitch
        (horizontal, vertical) pinhole pitch in SLM pixels; None: derived from the rig's
        optics (:func:`~sassi_bench.acquire.plan_geometry.scan_pitch`).
    every
        Keep every n-th pinhole offset first (a thinned scan is enough for a flat target).
    max_frames, de00_sigma_max
        The budget of pinhole frames and the response's colour 1-sigma to reach
        (None: :data:`~sassi_bench.reduce.response_budget.DEFAULT_MAX_FRAMES`,
        :data:`~sassi_bench.reduce.response_budget.DEFAULT_DE00_TOLERANCE`).
    sigma_max
        The worst bin's relative 1-sigma to reach as well; None: recorded only.
    session_id
        Id of the raw session; an existing id resumes.
    data
        Data root for sessions and bundles.
    progress
        Show progress bars.
    allow_failed
        Publish although a check failed, or derive from a parent published with an
        override.

    Returns
    -------
    pathlib.Path
        The new bundle's folder.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        path = run_response(rig, bundle, temperature_k=3100)
    """
    check_parent(bundle, "response", allow_failed=allow_failed)
    pitch = scan_pitch(rig.description, pitch)
    check_scan(rig, "white", light, pitch)
    source = response_source(rig.description, temperature_k, reference_csv)
    first = -(-pitch[0] * pitch[1] // every)
    settings = response_frame_settings(
        {"max_frames": max_frames, "de00_sigma_max": de00_sigma_max, "sigma_max": sigma_max},
        first,
    )
    budget = settings.budget
    session = Session.resume_or_plan(
        rig.description,
        lambda: refining_scan_plan(_plan(rig, "white", light, pitch, 1, 0.6), every, budget),
        session_id=session_id or _stamp("response"),
        data=data,
    )
    _check_response_session(session, every, budget)
    chart = response_colour_chart(bundle)
    frames, batches = settings.first, []
    while True:
        scan = capture_scan(rig, session, bundle, keep_raw=True, progress=progress, frames=frames)
        white = white_mean(scan, bundle)
        de00 = response_de00_sigma(white, chart)
        batch = decide_response_frames(frames, response_sigma(white), de00, settings, batches)
        batches.append(batch)
        if batch.next_frames is None:
            break
        frames = batch.next_frames
        release_memory()
    return publish_response(
        scan, session, bundle, rig.description, source, light=light, pitch=pitch, every=every,
        reflectance=reflectance, data=data, allow_failed=allow_failed,
        frames=ResponseFrameRecord(tuple(batches), settings, every),
    )  # fmt: skip


def response_colour_chart(bundle: CalibrationBundle) -> ColourChart:
    """The ColorChecker the response's colour error is computed on: the Macbeth
    validation's default reference averaged over the bundle's bins, with its colour
    matching (CIE 1931 2 degree observer, D65, :mod:`~sassi_bench.validate.colorimetry`).

    Examples
    --------
    Not run here (it needs a bundle)::

        chart = response_colour_chart(bundle)
        chart.reflectance.shape == (24, bundle.wavelengths.size)
        # True
    """
    lam = bundle.wavelengths
    return ColourChart(
        reference_chart(RESPONSE_CHART).bin_average(bundle.bin_edges),
        reflectance_to_xyz(lam, np.eye(lam.size)),
        white_chromaticity(),
    )


def _check_response_session(session: Session, every: int, budget: int) -> None:
    planned = session.plan.parameters
    if planned.get("every") != every or planned.get("max_frames") != budget:
        raise ConfigError(
            step_error(
                f"resume session {session.id}",
                f"its white frames were planned for every={planned.get('every')} and "
                f"max_frames={planned.get('max_frames')}, not every={every} and "
                f"max_frames={budget}",
                "resume with the same response settings, or start a new --session",
            )
        )


@drives_rig("scan")
def run_scan(
    rig: Rig,
    bundle: CalibrationBundle,
    *,
    scene: str = "colorchecker",
    light: str = "led",
    pitch: tuple[int, int] | None = None,
    roi: Sequence[int] | None = None,
    session_id: str | None = None,
    data=None,
    progress: bool = True,
    keep_raw: bool = False,
) -> ScanRun:
    """Capture (or resume) a pinhole scan of ``scene`` and assemble it with ``bundle``.

    Parameters
    ----------
    rig
        Device handles.
    bundle
        This rig's calibration bundle.
    scene
        The scene to scan.
    light
        The light to scan under.
    pitch
        (horizontal, vertical) pinhole pitch in SLM pixels; None: derived from the rig's
        optics (:func:`~sassi_bench.acquire.plan_geometry.scan_pitch`).
    roi
        Part of the SLM to assemble, or None for all of it.
    session_id
        Id of the raw session; an existing id resumes.
    data
        Data root for sessions.
    progress
        Show progress bars.
    keep_raw
        Also keep the column sums before the deblur (for spectra averaged first and
        deblurred once: the Macbeth patches).

    Returns
    -------
    ScanRun
        The assembled cube, whether it is radiance (the bundle has a response), the
        session and the bundle.

    Raises
    ------
    ProcedureError
        For a scan the rig cannot take, or a bundle of another SLM.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        run = run_scan(open_rig("sim"), load(rig="sim"), scene="white")
        run.scan.cube.shape
    """
    pitch = scan_pitch(rig.description, pitch)
    check_scan(rig, scene, light, pitch, roi)
    if tuple(bundle.slm_shape) != tuple(rig.slm.shape):
        raise ProcedureError(
            step_error(
                "scan",
                f"bundle is for a {bundle.slm_shape} SLM, the rig has {rig.slm.shape}",
                "load this rig's bundle",
            )
        )
    session = Session.resume_or_plan(
        rig.description,
        lambda: _plan(rig, scene, light, pitch, 1, 0.6),
        session_id=session_id or _stamp(f"scan-{scene}"),
        data=data,
    )
    scan = capture_scan(rig, session, bundle, roi=roi, keep_raw=keep_raw, progress=progress)
    return ScanRun(scan, bundle.response is not None, session, bundle)
