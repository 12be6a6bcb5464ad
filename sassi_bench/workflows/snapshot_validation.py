"""The snapshot validation on a rig: does a bundle give good SASSI snapshots?

:func:`run_snapshot` scans the scene with pinholes (the measured reference, or a scan
cube given on disk), takes an adaptive snapshot whose mask comes from the guide image,
reconstructs it by rank-1 per region and by the masked guided filter, and scores both
against the scan in the same bins on the SLM grid (:mod:`sassi_bench.validate.snapshot`).
Optionally it adds a photon-starved snapshot, uniform and random masks of the adaptive
mask's separation, and a video of a moving scene (each frame's mask from the previous guide
frame; each frame scored against the scan moved by the pose the procedure commanded). It
sees only device handles, never the virtual bench's hidden scene.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.plan_geometry import scan_pitch
from sassi_bench.acquire.snapshots import SnapshotVideo, capture_snapshots
from sassi_bench.bundle import CalibrationBundle, MaskSpacing, QualityCheck
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.snapshots import adaptive_planner, frame_samples, procedure_spacing
from sassi_bench.rig.rig import Rig
from sassi_bench.rig.scene_pose import ScenePose
from sassi_bench.snapshot import random_mask, reconstruct_frame, uniform_mask
from sassi_bench.spectra.cube_io import units_label
from sassi_bench.validate.snapshot import (
    MaskRun,
    SnapshotValidation,
    detail_pixels,
    frame_scores,
    load_mask,
    load_scan_cube,
    warp_cube,
)
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.scan import run_scan
from sassi_bench.workflows.snapshot import check_inputs

__all__ = ["run_snapshot"]


def _reconstruct(
    kind: str,
    video: SnapshotVideo,
    t: int,
    bundle: CalibrationBundle,
    spacing: MaskSpacing,
    procedure: Mapping[str, Any],
    reference: NDArray[np.float32],
    valid: NDArray[np.bool_],
    detail: NDArray[np.bool_],
    samples: NDArray[np.int32] | None = None,
) -> MaskRun:
    """Measure, segment, reconstruct and score frame ``t`` of a snapshot video (regions
    around ``samples`` when given, else around the adaptive samples or every open pixel)."""
    compactness = float(procedure["snapshot"]["compactness"])
    mask = video.mask(t)
    if samples is None:  # placed on the previous guide frame; regions follow this one
        samples = frame_samples(video, t, bundle, spacing, compactness)
    exposure = video.exposures.spectral_s
    recon = procedure["reconstruction"]
    frame = reconstruct_frame(
        bundle, video.guide(t), video.spectral(t), mask, exposure_s=exposure, samples=samples,
        compactness=compactness, guided_radius=recon["guided_radius_px"],
        guided_eps=recon["guided_eps"], closed=video.closed(t),
    )  # fmt: skip
    scores, detail_psnr, error_split = frame_scores(frame, reference, valid, detail)
    return MaskRun(
        kind=kind,
        mask=mask,
        samples=frame.samples,
        labels=frame.labels,
        guide_slm=frame.guide_slm,
        spectra=frame.spectra,
        rank1_factored=frame.rank1_factored,
        guided_factored=frame.guided_factored,
        scores=scores,
        detail_psnr_db=detail_psnr,
        error_split=error_split,
        sessions=[video.preview.id, video.frames[t].id],
        exposure_s=exposure,
        low_light=video.exposures.low_light,
    )


def _moved(cube: NDArray[np.float32], pose: ScenePose | None) -> NDArray[np.float32]:
    """The scan cube as the scene looks at ``pose`` (bilinear, edges repeated)."""
    if pose is None or pose.is_identity:
        return cube
    return warp_cube(cube, pose.canvas_matrix(cube.shape[:2], 0))


@drives_rig("validate snapshot")
def run_snapshot(
    rig: Rig,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    scene: str = "natural",
    scan_path: str | os.PathLike[str] | None = None,
    low_light: bool = False,
    video_frames: int = 0,
    mask_path: str | os.PathLike[str] | None = None,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> SnapshotValidation:
    """Scan, snapshot, reconstruct and score (see the module docstring).

    Parameters
    ----------
    rig, bundle
        Device handles and the bundle under test (it needs a guide homography).
    procedure
        ``load_procedure("snapshot_validation")``.
    scene
        Scene in front of the bench (``natural``, ``colorchecker``, ``pcb``, ``white``).
    scan_path
        A scan cube (NetCDF) to reuse instead of scanning.
    low_light
        Also take a photon-starved snapshot (``snapshot.low_light`` of the exposure) with
        the first snapshot's mask and samples, so the two differ by their photons alone.
    video_frames
        Also take a video of this many frames of the scene moving.
    mask_path
        A user's mask (``.npy``) instead of the adaptive one; checked against the rule.
    session_id
        Prefix of the raw sessions; an existing one resumes.
    data, progress
        Data root; progress bars.

    Returns
    -------
    SnapshotValidation
        The scan, every mask's run with its cubes and scores, the video's scores, the
        quality checks and the settings, for the report.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        result = run_snapshot(rig, bundle, load_procedure("snapshot_validation"))
        result.runs["adaptive"].scores["rank1"].psnr_affine_db
    """
    check_inputs(rig, bundle, scene)
    spacing = procedure_spacing(bundle, procedure)
    user_mask = None if mask_path is None else load_mask(mask_path, spacing)
    if isinstance(video_frames, bool) or not isinstance(video_frames, int) or video_frames < 0:
        raise ProcedureError(
            step_error("validate snapshot", f"video={video_frames!r}", "pass 0 or more frames")
        )
    prefix = session_id or "snapshot-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    snap, score_cfg = procedure["snapshot"], procedure["scoring"]
    light = snap["light"]
    notes: list[str] = []

    # 1. The reference: a pinhole scan of the scene (or a given scan cube).
    scan_dataset = None
    if scan_path is not None:
        reference, valid, units = load_scan_cube(scan_path, bundle)
        source = f"scan cube {Path(scan_path).name}"
    else:
        run = run_scan(
            rig, bundle, scene=scene, light=procedure["scan"]["light"],
            pitch=scan_pitch(rig.description, procedure["scan"]["pitch_px"]),
            session_id=f"{prefix}-scan", data=data, progress=progress,
        )  # fmt: skip
        ds = scan_dataset = run.dataset()
        # The reference is the dataset's radiance itself (float32 already, no copy).
        reference = np.asarray(
            ds["radiance"].transpose("y", "x", "wavelength").values, dtype=np.float32
        )
        valid = run.scan.quality == 0
        units = units_label(ds["radiance"])
        source = f"pinhole scan, session {run.session.id}"
        del run  # the scan's cube before the response is no longer needed
    border = int(score_cfg["border_px"])
    if border:
        edge = np.zeros(valid.shape, bool)
        edge[border:-border, border:-border] = True
        valid = valid & edge
    detail = detail_pixels(reference, valid, float(score_cfg["detail_fraction"]))

    # 2. Snapshots: adaptive (or the user's mask), photon-starved, comparison masks.
    exposure_pattern = {"kind": "pinholes", "pitch": [spacing.uniform_step, spacing.pitch]}
    adaptive_from = adaptive_planner(bundle, spacing, float(snap["compactness"]))

    def fixed(mask: NDArray[np.bool_]):
        return lambda guide: mask

    first = "user" if user_mask is not None else "adaptive"
    # (name, next mask, exposure factor); None: the first snapshot's mask and samples, so
    # the photon-starved snapshot differs from it by its photons alone.
    plans: list[tuple[str, Any, float]] = [
        (first, adaptive_from if user_mask is None else fixed(user_mask), 1.0)
    ]
    if low_light:
        plans.append((f"{first}_low_light", None, float(snap["low_light"])))
    for kind in snap["compare_masks"]:
        mask = (
            uniform_mask(spacing)
            if kind == "uniform"
            else random_mask(spacing, seed=int(snap["random_seed"]))
        )
        plans.append((kind, fixed(mask), 1.0))
    runs: dict[str, MaskRun] = {}
    for name, next_mask, factor in plans:
        samples = None
        if next_mask is None:
            next_mask, samples = fixed(runs[first].mask), runs[first].samples
        video = capture_snapshots(
            rig, next_mask, prefix=f"{prefix}-{name.replace('_', '-')}", scene=scene,
            light=light, exposure_pattern=exposure_pattern, low_light=factor,
            mask_kind=name.split("_")[0], closed_frame=bool(snap.get("closed_frame", True)),
            data=data, progress=False,
        )  # fmt: skip
        kind = "adaptive" if name.startswith("adaptive") else "fixed"
        runs[name] = _reconstruct(
            kind, video, 0, bundle, spacing, procedure, reference, valid, detail, samples
        )
        runs[name].kind = name.split("_")[0]

    # 3. Video of the moving scene, each frame scored against the scan moved to its pose.
    frames: list[dict[str, Any]] = []
    if video_frames:
        motion_cfg = procedure["video"]
        motion = (tuple(motion_cfg["shift_px_per_frame"]), motion_cfg["rotation_deg_per_frame"])
        video = capture_snapshots(
            rig, adaptive_from if user_mask is None else fixed(user_mask),
            prefix=f"{prefix}-video", frames=video_frames, scene=scene, light=light,
            exposure_pattern=exposure_pattern, motion=motion, mask_kind=first, data=data,
            progress=progress,
        )  # fmt: skip
        for t in range(video_frames):
            pose = video.pose(t)
            moved = _moved(reference, pose)
            inner = _moved(valid.astype(np.float32)[..., None], pose)[..., 0] > 0.999
            inner &= valid
            moved_detail = detail_pixels(moved, inner, float(score_cfg["detail_fraction"]))
            frame = _reconstruct(
                "adaptive" if user_mask is None else "fixed", video, t, bundle, spacing,
                procedure, moved, inner, moved_detail,
            )  # fmt: skip
            frames.append(
                {
                    "frame": t,
                    "pose": None if pose is None else pose.to_dict(),
                    "open_pixels": int(frame.mask.sum()),
                    "rank1": frame.scores["rank1"].to_dict(),
                    "guided": frame.scores["guided"].to_dict(),
                    "session": video.frames[t].id,
                }
            )
        notes.append(
            "Video frames are scored against the scan moved to the pose the procedure "
            "commanded (bilinear resampling), so their PSNR includes that resampling."
        )

    # 4. Grading.
    tol = procedure["tolerances"]
    main = runs[first]
    checks = [
        QualityCheck.at_least(
            "psnr_rank1_affine", main.scores["rank1"].psnr_affine_db,
            tol["min_psnr_rank1_db"], "dB",
        ),
        QualityCheck.at_least(
            "psnr_guided_affine", main.scores["guided"].psnr_affine_db,
            tol["min_psnr_guided_db"], "dB",
        ),
        QualityCheck.at_most(
            "spectral_angle_rank1", main.scores["rank1"].spectral_angle_deg,
            tol["max_spectral_angle_deg"], "deg",
        ),
    ]  # fmt: skip
    settings = {
        "rig": rig.description.name,
        "bundle": f"{bundle.rig_name}/{bundle.version}",
        "scene": scene,
        "light": light,
        "reference": source,
        "mask": first,
        "open pixels": int(main.mask.sum()),
        "spectral exposure (s)": round(main.exposure_s, 6),
        "row pitch (px)": spacing.pitch,
        "uniform step (px)": spacing.uniform_step,
        "session prefix": prefix,
    }
    return SnapshotValidation(
        scene=scene,
        rig_name=rig.description.name,
        bundle_version=bundle.version,
        reference=reference,
        reference_source=source,
        units=units,
        valid=valid,
        detail=detail,
        wavelengths_nm=np.asarray(bundle.wavelengths, dtype=np.float64),
        spacing={
            "pitch": spacing.pitch,
            "uniform_step": spacing.uniform_step,
            "min_left": int(spacing.left.min()),
            "max_left": int(spacing.left.max()),
            "min_right": int(spacing.right.min()),
            "max_right": int(spacing.right.max()),
        },
        runs=runs,
        video=frames,
        checks=checks,
        settings=settings,
        notes=notes,
        scan_dataset=scan_dataset,
    )
