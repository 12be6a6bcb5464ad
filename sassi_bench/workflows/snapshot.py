"""SASSI snapshots as a lab takes them: adaptive masks shown and captured.

:func:`take_snapshots` shows the adaptive mask of the latest guide image (video mode: the
mask of frame t comes from the guide image of frame t-1) and stores every frame in a raw
session, like every other capture; :func:`~sassi_bench.reduce.snapshots.reconstruct_snapshots`
turns them into cubes. ``sassi-bench snapshot take`` runs both.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from sassi_bench.acquire.snapshots import SnapshotVideo, capture_snapshots
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.snapshots import adaptive_planner, procedure_spacing
from sassi_bench.rig.rig import Rig, check_scene
from sassi_bench.workflows.rig_lock import drives_rig

__all__ = ["check_inputs", "take_snapshots"]


def check_inputs(
    rig: Rig, bundle: CalibrationBundle, scene: str, step: str = "validate snapshot"
) -> None:
    """Refuse a bad scene or a bundle that cannot take snapshots, before any capture.

    Parameters
    ----------
    rig
        Device handles.
    bundle
        The bundle that will draw the masks and reconstruct (it needs a guide homography and
        the rig's SLM).
    scene
        The scene to put in front of the bench.
    step
        The command or step named in the error.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        check_inputs(open_rig("sim"), load(rig="sim"), "natral")
        # Traceback (most recent call last):
        # ProcedureError: validate snapshot: unknown scene 'natral'
        # (did you mean 'natural'?). Fix: ...
    """
    check_scene(scene, step=step)
    if bundle.guide_to_slm is None:
        raise ProcedureError(
            step_error(
                step,
                f"bundle {bundle.rig_name}/{bundle.version} has no guide -> SLM homography, "
                "so adaptive masks cannot be drawn from the guide image",
                "run `sassi-bench calibrate guide` (or the full `sassi-bench calibrate`) and "
                "validate the bundle it publishes",
            )
        )
    if tuple(bundle.slm_shape) != tuple(rig.slm.shape):
        raise ProcedureError(
            step_error(
                step,
                f"bundle {bundle.rig_name}/{bundle.version} is for a {bundle.slm_shape} SLM, "
                f"the rig has {rig.slm.shape}",
                "load this rig's bundle (--bundle)",
            )
        )


@drives_rig("snapshot take")
def take_snapshots(
    rig: Rig,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    scene: str,
    frames: int = 1,
    low_light: float = 1.0,
    moving: bool = False,
    session_id: str,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> SnapshotVideo:
    """Capture (or resume) ``frames`` adaptive snapshots of ``scene``.

    Parameters
    ----------
    rig, bundle
        Device handles and the bundle whose homography and spacing rule draw the masks.
    procedure
        ``load_procedure("snapshot_validation")``: its ``snapshot`` (light, compactness,
        row pitch, closed frame) and ``video`` (motion) sections. A still scene's frames
        also take the closed SLM when ``snapshot.closed_frame`` says so (the default); a
        moving scene's take none, as it moves between the two exposures.
    scene
        What is in front of the bench.
    frames
        Snapshot frames; each frame's mask comes from the previous frame's guide image.
    low_light
        Factor on the spectral exposure (0.02: a photon-starved frame).
    moving
        Move the scene between frames by the procedure's ``video`` motion (virtual bench).
    session_id
        Prefix of the raw sessions ``<id>-preview`` and ``<id>-fNNN``; an existing one
        resumes.
    data, progress
        Data root; progress bar over the frames.

    Returns
    -------
    SnapshotVideo

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        video = take_snapshots(rig, bundle, load_procedure("snapshot_validation"),
                               scene="natural", session_id="snap")
        len(video.frames)
        # 1
    """
    check_inputs(rig, bundle, scene, step="snapshot take")
    if not (np.isfinite(low_light) and 0 < low_light <= 1):
        raise ProcedureError(
            step_error("snapshot take", f"low light {low_light}", "give a factor in (0, 1]")
        )
    spacing = procedure_spacing(bundle, procedure)
    snap = procedure["snapshot"]
    next_mask = adaptive_planner(bundle, spacing, float(snap["compactness"]))
    motion = None
    if moving:
        cfg = procedure["video"]
        motion = (tuple(cfg["shift_px_per_frame"]), float(cfg["rotation_deg_per_frame"]))
    return capture_snapshots(
        rig, next_mask, prefix=session_id, frames=frames, scene=scene, light=snap["light"],
        exposure_pattern={"kind": "pinholes", "pitch": [spacing.uniform_step, spacing.pitch]},
        low_light=low_light, motion=motion, mask_kind="adaptive",
        closed_frame=bool(snap.get("closed_frame", True)) and not moving, data=data,
        progress=progress,
    )  # fmt: skip
