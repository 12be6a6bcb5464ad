"""SASSI snapshots: the SLM shows a mask, the guide and the spectral camera capture.

A snapshot video is stored as sessions that share a prefix, so no frame is ever
planned before the frame it depends on exists:

``<prefix>-preview``
    One guide frame taken before the first snapshot (the camera's previous frame).
    Its plan parameters hold the exposures of the whole video, fixed once.
``<prefix>-f000``, ``<prefix>-f001``, ...
    One session per frame, with two steps: the guide frame (step 0) and the spectral
    frame (step 1), both taken while the SLM shows that frame's mask. The mask is
    stored exactly as a ``pixels`` pattern descriptor (the open pixels' rows and
    columns, see :func:`~sassi_bench.acquire.patterns.pixels_descriptor`) in both
    steps, so :func:`snapshot_mask` gives it back from the session alone. With a
    closed-SLM frame (``closed_frame=True``) a third step (step 2) takes the spectral
    camera with every SLM pixel closed, at the same exposure: the closed pixels' leak
    the snapshot's spectra then subtract pixel by pixel.

The mask of frame ``t`` is computed from the guide image of frame ``t - 1`` (the
preview for ``t = 0``) by a caller-supplied function, so this module depends on no
reconstruction code. A finished frame session is never planned again: an interrupted
video resumes by calling :func:`capture_snapshots` with the same prefix, which re-reads
the last finished guide image and carries on.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.patterns import pixels_descriptor, render_pattern
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.rig.rig import Rig
from sassi_bench.rig.scene_pose import ScenePose

__all__ = [
    "CLOSED_STEP",
    "GUIDE_STEP",
    "SPECTRAL_STEP",
    "SnapshotExposures",
    "SnapshotVideo",
    "capture_snapshots",
    "snapshot_exposures",
    "snapshot_mask",
    "snapshot_plan",
]

GUIDE_STEP = 0
"""Index of the guide frame in a snapshot frame session."""
SPECTRAL_STEP = 1
"""Index of the spectral frame in a snapshot frame session."""
CLOSED_STEP = 2
"""Index of the closed-SLM spectral frame in a snapshot frame session that has one."""


@dataclass(frozen=True)
class SnapshotExposures:
    """Exposures (s) of a snapshot video, and the low-light factor applied to them.

    ``spectral_s`` already includes ``low_light``: a photon-starved snapshot exposes
    the spectral camera ``low_light`` times as long as a well-exposed one would.
    """

    spectral_s: float
    guide_s: float
    low_light: float = 1.0

    def to_dict(self) -> dict[str, float]:
        return {"spectral_s": self.spectral_s, "guide_s": self.guide_s, "low_light": self.low_light}


def snapshot_exposures(
    rig: Rig,
    light: str,
    exposure_pattern: Mapping[str, Any],
    *,
    low_light: float = 1.0,
    target_fraction: float = 0.6,
) -> SnapshotExposures:
    """Auto-expose both cameras for snapshots, then starve the spectral one if asked.

    Parameters
    ----------
    rig
        Device handles; the scene must already be in front of the bench.
    light
        The light the snapshots are taken under.
    exposure_pattern
        A pattern of the masks' density (e.g. pinholes at the mask separation) to
        expose the spectral camera for.
    low_light
        Factor (0, 1] on the spectral exposure: 1 is well exposed, 0.02 a photon-starved
        frame with 50 times fewer photons (read noise then matters).
    target_fraction
        Level of the brightest pixels as a fraction of the ADC range.

    Examples
    --------
    Not run here (it drives a bench or reads its sessions)::

        from sassi_bench import open_rig
        rig = open_rig("sim")
        e = snapshot_exposures(rig, "led", {"kind": "pinholes", "pitch": [80, 5]},
                               low_light=0.1)
    """
    if not 0 < low_light <= 1:
        raise ProcedureError(
            step_error(
                "snapshot exposure",
                f"low-light factor {low_light!r} is not in (0, 1]",
                "pass 1 for a normal exposure or e.g. 0.02 for a photon-starved one",
            )
        )
    spectral = auto_exposure(rig, light, exposure_pattern, target_fraction=target_fraction)
    guide = auto_exposure(
        rig, light, {"kind": "blank"}, camera="guide", target_fraction=target_fraction
    )
    lo, _ = rig.spectral_camera.exposure_range_s
    return SnapshotExposures(max(spectral * low_light, lo), guide, low_light)


def snapshot_plan(
    mask: NDArray[np.bool_],
    light: str,
    exposures: SnapshotExposures,
    *,
    frame: int = 0,
    scene: str | None = None,
    pose: ScenePose | None = None,
    mask_kind: str = "adaptive",
    closed_frame: bool = False,
) -> Plan:
    """The plan of one snapshot frame: guide then spectral, with ``mask`` on the SLM, then
    (``closed_frame``) a spectral frame of the closed SLM at the same exposure.

    Examples
    --------
    >>> mask = np.zeros((4, 6), bool)
    >>> mask[1, 2] = True
    >>> plan = snapshot_plan(mask, "led", SnapshotExposures(0.1, 0.02), frame=3)
    >>> [s.camera for s in plan], plan.steps[1].pattern["cols"], plan.parameters["frame"]
    (['guide', 'spectral'], (2,), 3)
    >>> plan = snapshot_plan(mask, "led", SnapshotExposures(0.1, 0.02), closed_frame=True)
    >>> plan.steps[CLOSED_STEP].pattern["kind"], plan.steps[CLOSED_STEP].tags["role"]
    ('blank', 'closed')
    """
    descriptor = pixels_descriptor(np.asarray(mask, dtype=bool))
    tags = {"frame": int(frame), "mask_kind": mask_kind}
    steps = (
        Step("guide", light, exposures.guide_s, descriptor, {"role": "guide", **tags}),
        Step("spectral", light, exposures.spectral_s, descriptor, {"role": "snapshot", **tags}),
    )
    if closed_frame:
        blank = {"kind": "blank"}
        steps += (Step("spectral", light, exposures.spectral_s, blank, {"role": "closed", **tags}),)
    parameters: dict[str, Any] = {
        "frame": int(frame),
        "light": light,
        "mask_kind": mask_kind,
        "open_pixels": len(descriptor["rows"]),
        "exposures": exposures.to_dict(),
    }
    if scene is not None:
        parameters["scene"] = scene
    if pose is not None and not pose.is_identity:
        parameters["scene_pose"] = pose.to_dict()
    return Plan(f"snapshot-f{int(frame):03d}", steps, parameters)


def snapshot_mask(session: Session) -> NDArray[np.bool_]:
    """The mask the SLM showed for a snapshot session's spectral frame, as (H, W) bool.

    Examples
    --------
    Not run here (it drives a bench or reads its sessions)::

        mask = snapshot_mask(Session.open("video-f002"))
    """
    step = session.plan.steps[SPECTRAL_STEP] if len(session.plan) > SPECTRAL_STEP else None
    if step is None or step.tags.get("role") != "snapshot":
        raise ProcedureError(
            step_error(
                "snapshot mask",
                f"session {session.id!r} is not a snapshot frame (plan {session.plan.name!r})",
                "open a <prefix>-fNNN session written by capture_snapshots",
            )
        )
    shape = (int(session.rig["slm"]["height"]), int(session.rig["slm"]["width"]))
    return render_pattern(step.pattern, shape) > 0


@dataclass(frozen=True)
class SnapshotVideo:
    """The sessions of a snapshot video (a single snapshot is a video of one frame)."""

    preview: Session
    frames: tuple[Session, ...]

    @property
    def exposures(self) -> SnapshotExposures:
        e = self.preview.plan.parameters["exposures"]
        return SnapshotExposures(float(e["spectral_s"]), float(e["guide_s"]), float(e["low_light"]))

    def mask(self, t: int) -> NDArray[np.bool_]:
        """The mask of frame ``t``."""
        return snapshot_mask(self.frames[t])

    def guide(self, t: int) -> NDArray[Any]:
        """The guide image (H, W, 3) of frame ``t`` (``-1``: the preview)."""
        session = self.preview if t == -1 else self.frames[t]
        return session.read_frame(GUIDE_STEP)

    def spectral(self, t: int) -> NDArray[Any]:
        """The spectral frame of frame ``t``."""
        return self.frames[t].read_frame(SPECTRAL_STEP)

    def closed(self, t: int) -> NDArray[Any] | None:
        """The closed-SLM spectral frame of frame ``t`` (None: the frame took none)."""
        steps = self.frames[t].plan.steps
        if len(steps) <= CLOSED_STEP or steps[CLOSED_STEP].tags.get("role") != "closed":
            return None
        return self.frames[t].read_frame(CLOSED_STEP)

    def pose(self, t: int) -> ScenePose | None:
        """The scene pose the plan of frame ``t`` set (``None``: not set, a static scene)."""
        pose = self.frames[t].plan.parameters.get("scene_pose")
        return None if pose is None else ScenePose.from_dict(pose)


def _pose(motion: tuple[tuple[float, float], float] | None, t: int) -> ScenePose | None:
    if motion is None:
        return None
    return ScenePose.at_frame(t, motion[0], motion[1])


def capture_snapshots(
    rig: Rig,
    next_mask: Callable[[NDArray[Any]], NDArray[np.bool_]],
    *,
    prefix: str,
    frames: int = 1,
    scene: str,
    light: str = "led",
    exposure_pattern: Mapping[str, Any],
    low_light: float = 1.0,
    motion: tuple[tuple[float, float], float] | None = None,
    mask_kind: str = "adaptive",
    closed_frame: bool = False,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> SnapshotVideo:
    """Capture (or resume) a snapshot video whose mask for frame t follows frame t-1.

    Parameters
    ----------
    rig
        Device handles.
    next_mask
        Maps a raw guide image (H, W, 3) to the next frame's (H_slm, W_slm) bool mask
        (e.g. the adaptive mask of the guide image warped to the SLM; or a fixed mask).
    prefix
        Session id prefix: ``<prefix>-preview`` and ``<prefix>-fNNN``.
    frames
        Number of snapshot frames.
    scene, light
        What is in front of the bench and under which light.
    exposure_pattern
        Pattern descriptor of the masks' density, for the auto-exposure.
    low_light
        Factor on the spectral exposure (see :func:`snapshot_exposures`).
    motion
        ``((dx, dy), degrees)`` per frame: frame t is shown at
        ``ScenePose.at_frame(t, ...)``, the preview at t = -1. ``None``: static.
    mask_kind
        Recorded in each frame's plan (``adaptive``, ``uniform``, ``random``, ``user``).
    closed_frame
        Also take a spectral frame of the closed SLM after each snapshot, at its exposure
        (:data:`CLOSED_STEP`; one more spectral frame a snapshot): the leak the spectra
        subtract. Exact for a still scene; a moving one changes between the two frames.
        A session already planned keeps its plan.
    data
        Data root.
    progress
        Progress bar over the frames.

    Returns
    -------
    SnapshotVideo

    Examples
    --------
    Not run here (it drives a bench or reads its sessions)::

        from sassi_bench import open_rig
        rig = open_rig("sim")
        fixed = np.zeros(rig.slm.shape, bool)
        fixed[::5, ::80] = True
        video = capture_snapshots(rig, lambda guide: fixed, prefix="demo", scene="natural",
            exposure_pattern={"kind": "pinholes", "pitch": [80, 5]})
        bool((video.mask(0) == fixed).all())
        # True
    """
    from tqdm.auto import tqdm

    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise ProcedureError(
            step_error("snapshot capture", f"frames={frames!r}", "ask for one frame or more")
        )

    def preview_plan() -> Plan:
        rig.set_scene(scene, _pose(motion, 0))
        exposures = snapshot_exposures(rig, light, exposure_pattern, low_light=low_light)
        step = Step("guide", light, exposures.guide_s, {"kind": "blank"}, {"role": "preview"})
        parameters: dict[str, Any] = {"scene": scene, "light": light}
        parameters["exposures"] = exposures.to_dict()
        pose = _pose(motion, -1)
        if pose is not None:
            parameters["scene_pose"] = pose.to_dict()
            parameters["motion"] = {"shift_px": list(motion[0]), "rotation_deg": motion[1]}
        return Plan("snapshot-preview", (step,), parameters)

    preview = Session.resume_or_plan(
        rig.description, preview_plan, session_id=f"{prefix}-preview", data=data
    )
    run_plan(rig, preview.plan, preview, progress=False)
    video = SnapshotVideo(preview, ())
    exposures = video.exposures
    guide = video.guide(-1)
    sessions = []
    for t in tqdm(range(frames), desc=f"snapshots {prefix}", disable=not progress):

        def plan(t: int = t, guide: NDArray[Any] = guide) -> Plan:
            mask = next_mask(guide)
            return snapshot_plan(
                mask, light, exposures, frame=t, scene=scene, pose=_pose(motion, t),
                mask_kind=mask_kind, closed_frame=closed_frame,
            )  # fmt: skip

        session = Session.resume_or_plan(
            rig.description, plan, session_id=f"{prefix}-f{t:03d}", data=data
        )
        run_plan(rig, session.plan, session, progress=False)
        sessions.append(session)
        guide = session.read_frame(GUIDE_STEP)
    return SnapshotVideo(preview, tuple(sessions))
