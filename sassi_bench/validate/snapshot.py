"""The snapshot validation: does a bundle give good SASSI snapshots?

:func:`run_snapshot` scans the scene with pinholes (the ground truth, or a scan cube
given on disk), takes an adaptive snapshot whose mask comes from the guide image,
reconstructs it by rank-1 per region and by the masked guided filter, and scores both
against the scan in the same bins on the SLM grid. Optionally it adds a photon-starved
snapshot, uniform and random masks of the adaptive mask's separation, and a video of a
moving scene (each frame's mask from the previous guide frame; each frame scored against
the scan moved by the pose the procedure commanded). It never sees the bench's truth.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.snapshots import SnapshotVideo, capture_snapshots
from sassi_bench.bundle import CalibrationBundle, MaskSpacing, QualityCheck
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.rig.rig import SCENES, Rig
from sassi_bench.rig.scene_pose import ScenePose
from sassi_bench.snapshot import (
    band_psnr,
    check_mask,
    mean_spectral_angle_deg,
    psnr,
    random_mask,
    rank1_cube,
    reconstruct_frame,
    ssim,
    uniform_mask,
)
from sassi_bench.workflows.snapshot import adaptive_planner, frame_samples, procedure_spacing

__all__ = [
    "MaskRun",
    "Scores",
    "SnapshotValidation",
    "check_inputs",
    "load_mask",
    "load_scan_cube",
    "run_snapshot",
]


def check_inputs(rig: Rig, bundle: CalibrationBundle, scene: str) -> None:
    """Refuse a bad scene or a bundle that cannot take snapshots, before any capture."""
    if scene not in SCENES:
        raise ProcedureError(
            step_error(
                "validate snapshot", f"unknown scene {scene!r}", f"use one of {', '.join(SCENES)}"
            )
        )
    if bundle.guide_to_slm is None:
        raise ProcedureError(
            step_error(
                "validate snapshot",
                f"bundle {bundle.rig_name}/{bundle.version} has no guide -> SLM homography, "
                "so adaptive masks cannot be drawn from the guide image",
                "run `sassi-bench calibrate guide` (or the full `sassi-bench calibrate`) and "
                "validate the bundle it publishes",
            )
        )
    if tuple(bundle.slm_shape) != tuple(rig.slm.shape):
        raise ProcedureError(
            step_error(
                "validate snapshot",
                f"bundle {bundle.rig_name}/{bundle.version} is for a {bundle.slm_shape} SLM, "
                f"the rig has {rig.slm.shape}",
                "load this rig's bundle (--bundle)",
            )
        )


def load_mask(path: str | os.PathLike[str], spacing: MaskSpacing) -> NDArray[np.bool_]:
    """A user's mask from a ``.npy`` file, checked against the bundle's spacing rule."""
    try:
        array = np.load(Path(path), allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise ProcedureError(
            step_error(
                "validate snapshot --mask",
                f"cannot read {path} as a NumPy array ({exc})",
                "save the mask with numpy.save as an (H, W) bool array of the SLM's shape",
            )
        ) from exc
    if array.dtype != bool and array.dtype.kind in "iu" and set(np.unique(array)) <= {0, 1}:
        array = array.astype(bool)
    return check_mask(array, spacing)


def load_scan_cube(
    path: str | os.PathLike[str], bundle: CalibrationBundle
) -> tuple[NDArray[np.float32], NDArray[np.bool_], str]:
    """A scan cube written by ``sassi-bench scan`` (NetCDF): cube, valid pixels, units."""
    import xarray as xr

    try:
        ds = xr.open_dataset(Path(path))
    except (OSError, ValueError) as exc:
        raise ProcedureError(
            step_error(
                "validate snapshot --scan",
                f"cannot open {path} ({exc})",
                "pass a NetCDF cube written by `sassi-bench scan --out CUBE.nc`",
            )
        ) from exc
    with ds:
        name = "radiance" if "radiance" in ds else next(iter(ds.data_vars))
        cube = ds[name].transpose("y", "x", "wavelength").values.astype(np.float32)
        lam = ds["wavelength"].values
        quality = ds["quality"].values if "quality" in ds else np.zeros(cube.shape[:2], np.uint8)
        units = str(ds[name].attrs.get("units", ds.attrs.get("units", "")))
    if cube.shape[:2] != tuple(bundle.slm_shape) or lam.size != bundle.wavelengths.size:
        raise ProcedureError(
            step_error(
                "validate snapshot --scan",
                f"the cube {path} is {cube.shape} (y, x, bins); the bundle needs "
                f"{(*bundle.slm_shape, bundle.wavelengths.size)}",
                "scan the whole SLM with this bundle (no --roi), or omit --scan",
            )
        )
    if not np.allclose(lam, bundle.wavelengths, atol=0.05):
        raise ProcedureError(
            step_error(
                "validate snapshot --scan",
                f"the cube's bins ({lam[0]:.1f}..{lam[-1]:.1f} nm) are not the bundle's",
                "scan with the bundle under test, or omit --scan",
            )
        )
    return cube, quality == 0, units


@dataclass(frozen=True)
class Scores:
    """A reconstruction against the reference, over the scored pixels."""

    psnr_db: float
    psnr_affine_db: float
    ssim: float
    spectral_angle_deg: float
    band_psnr_db: NDArray[np.float64]

    @classmethod
    def of(cls, estimate: NDArray, reference: NDArray, valid: NDArray[np.bool_]) -> Scores:
        """PSNR (raw, and after one affine fit for the cube), SSIM (over the scored
        pixels' bounding box, unscored pixels set to the reference), mean spectral angle
        and per-band PSNR."""
        rows, cols = np.nonzero(valid)
        box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
        inside = np.where(valid[box][..., None], estimate[box], reference[box])
        return cls(
            psnr(reference, estimate, valid=valid),
            psnr(reference, estimate, valid=valid, affine=True),
            ssim(reference[box], inside),
            mean_spectral_angle_deg(reference, estimate, valid=valid),
            np.asarray(band_psnr(reference, estimate, valid=valid), dtype=np.float64),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "psnr_db": self.psnr_db,
            "psnr_affine_db": self.psnr_affine_db,
            "ssim": self.ssim,
            "spectral_angle_deg": self.spectral_angle_deg,
            "band_psnr_db": self.band_psnr_db.tolist(),
        }


@dataclass
class MaskRun:
    """One snapshot: its mask, regions, reconstructions and scores.

    ``error_split`` separates the two sources of error: ``samples_psnr_db``, the measured
    spectra at the open pixels against the scan's there (calibration and extraction), and
    ``rank1_from_scan_psnr_db``, rank-1 fed with the scan's own spectra at the open pixels
    (after the affine fit): the best this mask and these regions allow, whatever the
    calibration.
    """

    kind: str
    mask: NDArray[np.bool_]
    samples: NDArray[np.int32]
    labels: NDArray[np.int32]
    guide_slm: NDArray[np.float32]
    spectra: NDArray[np.float64]
    rank1: NDArray[np.float32]
    guided: NDArray[np.float32]
    scores: dict[str, Scores]
    detail_psnr_db: dict[str, float]
    error_split: dict[str, float]
    sessions: list[str]
    exposure_s: float
    low_light: float = 1.0


@dataclass
class SnapshotValidation:
    """Everything the report shows (``scan_dataset``: the scan taken, as an xarray
    Dataset, so it can be saved and reused with ``--scan``; None when one was given)."""

    scene: str
    rig_name: str
    bundle_version: str
    reference: NDArray[np.float32]
    reference_source: str
    units: str
    valid: NDArray[np.bool_]
    detail: NDArray[np.bool_]
    wavelengths_nm: NDArray[np.float64]
    spacing: dict[str, Any]
    runs: dict[str, MaskRun]
    video: list[dict[str, Any]]
    checks: list[QualityCheck]
    settings: dict[str, Any]
    notes: list[str] = field(default_factory=list)
    scan_dataset: Any = None
    created: str = field(default_factory=lambda: datetime.now(UTC).isoformat(timespec="seconds"))

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def summary(self) -> dict[str, float]:
        out: dict[str, float] = {}
        for name, run in self.runs.items():
            for method, s in run.scores.items():
                out[f"{name}_{method}_psnr_db"] = s.psnr_db
                out[f"{name}_{method}_psnr_affine_db"] = s.psnr_affine_db
        return out


def _detail_pixels(reference: NDArray, valid: NDArray, fraction: float) -> NDArray[np.bool_]:
    """Pixels of strongest spatial gradient in the scan (edges, thin tracks)."""
    import cv2

    image = reference.sum(axis=2).astype(np.float32)
    gx = cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=3)
    gradient = np.hypot(gx, gy)
    threshold = np.quantile(gradient[valid], 1.0 - fraction)
    return valid & (gradient >= threshold)


def _psnr_on(estimate: NDArray, reference: NDArray, pixels: NDArray, peak: float) -> float:
    mse = float(np.mean((estimate[pixels].astype(np.float64) - reference[pixels]) ** 2))
    return float(10.0 * np.log10(peak**2 / max(mse, 1e-30)))


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
        guided_eps=recon["guided_eps"],
    )  # fmt: skip
    rank, guided = frame.rank1, frame.guided
    peak = float(reference[valid].max())
    rows, cols = np.nonzero(mask)
    scored = valid[rows, cols]
    at_samples = reference[rows, cols].astype(np.float64)
    from_scan = rank1_cube(frame.guide_slm, frame.labels, mask, np.nan_to_num(at_samples))
    error_split = {
        "samples_psnr_db": _psnr_on(frame.spectra, at_samples, scored, peak),
        "rank1_from_scan_psnr_db": psnr(reference, from_scan, valid=valid, affine=True),
    }
    return MaskRun(
        kind=kind,
        mask=mask,
        samples=frame.samples,
        labels=frame.labels,
        guide_slm=frame.guide_slm,
        spectra=frame.spectra,
        rank1=rank,
        guided=guided,
        scores={
            "rank1": Scores.of(rank, reference, valid),
            "guided": Scores.of(guided, reference, valid),
        },
        detail_psnr_db={
            "rank1": _psnr_on(rank, reference, detail, peak),
            "guided": _psnr_on(guided, reference, detail, peak),
        },
        error_split=error_split,
        sessions=[video.preview.id, video.frames[t].id],
        exposure_s=exposure,
        low_light=video.exposures.low_light,
    )


def _moved(cube: NDArray[np.float32], pose: ScenePose | None) -> NDArray[np.float32]:
    """The scan cube as the scene looks at ``pose`` (bilinear, edges repeated)."""
    import cv2

    if pose is None or pose.is_identity:
        return cube
    matrix = pose.canvas_matrix(cube.shape[:2], 0)
    out = np.empty_like(cube)
    for start in range(0, cube.shape[2], 256):  # OpenCV warps at most 512 channels at once
        block = np.ascontiguousarray(cube[..., start : start + 256])
        warped = cv2.warpAffine(
            block, matrix, (cube.shape[1], cube.shape[0]),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE,
        )  # fmt: skip
        out[..., start : start + 256] = warped.reshape(block.shape)
    return out


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

    Examples
    --------
    >>> result = run_snapshot(rig, bundle, load_procedure("snapshot_validation"))  # doctest: +SKIP
    >>> result.runs["adaptive"].scores["rank1"].psnr_affine_db  # doctest: +SKIP
    """
    from sassi_bench.workflows.scan import run_scan

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

    # 1. The ground truth: a pinhole scan of the scene (or a given scan cube).
    scan_dataset = None
    if scan_path is not None:
        reference, valid, units = load_scan_cube(scan_path, bundle)
        source = f"scan cube {Path(scan_path).name}"
    else:
        run = run_scan(
            rig, bundle, scene=scene, light=procedure["scan"]["light"],
            pitch=tuple(procedure["scan"]["pitch_px"]), session_id=f"{prefix}-scan", data=data,
            progress=progress,
        )  # fmt: skip
        ds = scan_dataset = run.dataset()
        reference = ds["radiance"].transpose("y", "x", "wavelength").values.astype(np.float32)
        valid = run.scan.quality == 0
        units = str(ds["radiance"].attrs.get("units", ""))
        source = f"pinhole scan, session {run.session.id}"
    border = int(score_cfg["border_px"])
    if border:
        edge = np.zeros(valid.shape, bool)
        edge[border:-border, border:-border] = True
        valid = valid & edge
    detail = _detail_pixels(reference, valid, float(score_cfg["detail_fraction"]))

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
            mask_kind=name.split("_")[0], data=data, progress=False,
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
            moved_detail = _detail_pixels(moved, inner, float(score_cfg["detail_fraction"]))
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
