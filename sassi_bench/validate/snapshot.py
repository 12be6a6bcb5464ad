"""Scoring SASSI snapshots against a scan: the result types of the snapshot validation,
its scores (PSNR raw and after an affine fit, SSIM, spectral angle, per-band and detail PSNR,
and where the error comes from), and its inputs on disk (a scan cube, a user's mask).

Pure functions on arrays and files; :func:`sassi_bench.workflows.snapshot_validation.run_snapshot`
captures and reconstructs the snapshots and scores them here.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle import CalibrationBundle, MaskSpacing, QualityCheck
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot import (
    FrameReconstruction,
    band_psnr,
    check_mask,
    mean_spectral_angle_deg,
    psnr,
    rank1_cube,
    ssim,
)
from sassi_bench.spectra.cube_io import units_label

__all__ = [
    "MaskRun",
    "ScanReference",
    "Scores",
    "SnapshotValidation",
    "detail_pixels",
    "frame_scores",
    "load_mask",
    "load_scan_cube",
    "warp_cube",
]


class ScanReference(NamedTuple):
    """The ground truth a snapshot is scored against: a scan cube on the SLM grid."""

    cube: NDArray[np.float32]
    """(H, W, bins) radiance."""
    valid: NDArray[np.bool_]
    """(H, W) pixels the scan did not flag."""
    units: str
    """The cube's units."""


def load_mask(path: str | os.PathLike[str], spacing: MaskSpacing) -> NDArray[np.bool_]:
    """A user's mask from a ``.npy`` file, checked against the bundle's spacing rule.

    Examples
    --------
    >>> mask = load_mask("mask.npy", bundle.mask_spacing())  # doctest: +SKIP
    """
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


def load_scan_cube(path: str | os.PathLike[str], bundle: CalibrationBundle) -> ScanReference:
    """A scan cube written by ``sassi-bench scan`` (NetCDF), checked against ``bundle``'s SLM
    and bins.

    Examples
    --------
    >>> reference = load_scan_cube("scan.nc", load(rig="sim"))  # doctest: +SKIP
    >>> reference.cube.shape, reference.units  # doctest: +SKIP
    ((400, 640, 68), 'W/(sr m^2 nm)')
    """
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
        units = units_label(ds[name]) or str(ds.attrs.get("units", ""))
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
    return ScanReference(cube, quality == 0, units)


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


def detail_pixels(reference: NDArray, valid: NDArray, fraction: float) -> NDArray[np.bool_]:
    """Pixels of strongest spatial gradient in the scan (edges, thin tracks): the top
    ``fraction`` of the valid pixels by the gradient magnitude of the band sum.

    Examples
    --------
    >>> cube = np.zeros((8, 8, 2), np.float32); cube[:, 4:] = 1
    >>> detail_pixels(cube, np.ones((8, 8), bool), 0.25)[0].nonzero()[0].tolist()
    [3, 4]
    """
    import cv2

    image = reference.sum(axis=2).astype(np.float32)
    gx = cv2.Sobel(image, cv2.CV_32F, 1, 0, ksize=3)
    gy = cv2.Sobel(image, cv2.CV_32F, 0, 1, ksize=3)
    gradient = np.hypot(gx, gy)
    threshold = np.quantile(gradient[valid], 1.0 - fraction)
    return valid & (gradient >= threshold)


def warp_cube(cube: NDArray[np.float32], matrix: NDArray[np.float64]) -> NDArray[np.float32]:
    """``cube`` resampled through the 2 x 3 affine map ``matrix`` (output -> input pixel,
    bilinear, edges repeated): the scan as the scene looks at another pose.

    Examples
    --------
    >>> cube = np.arange(12, dtype=np.float32).reshape(2, 3, 2)
    >>> shift = np.array([[1.0, 0, 1], [0, 1, 0]])  # each output pixel reads one to its right
    >>> warp_cube(cube, shift)[0, :, 0].tolist()
    [2.0, 4.0, 4.0]
    """
    import cv2

    out = np.empty_like(cube)
    for start in range(0, cube.shape[2], 256):  # OpenCV warps at most 512 channels at once
        block = np.ascontiguousarray(cube[..., start : start + 256])
        warped = cv2.warpAffine(
            block, matrix, (cube.shape[1], cube.shape[0]),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE,
        )  # fmt: skip
        out[..., start : start + 256] = warped.reshape(block.shape)
    return out


def frame_scores(
    frame: FrameReconstruction,
    reference: NDArray[np.float32],
    valid: NDArray[np.bool_],
    detail: NDArray[np.bool_],
) -> tuple[dict[str, Scores], dict[str, float], dict[str, float]]:
    """Score one reconstructed frame against the scan.

    Parameters
    ----------
    frame
        The reconstruction (rank-1 and guided cubes, the measured spectra at the open pixels,
        its regions).
    reference
        (H, W, bins) scan cube on the SLM grid, at the pose of the frame.
    valid
        (H, W) pixels to score.
    detail
        (H, W) pixels of strongest gradient (:func:`detail_pixels`).

    Returns
    -------
    scores : dict
        :class:`Scores` of ``rank1`` and ``guided``.
    detail_psnr_db : dict
        PSNR of ``rank1`` and ``guided`` on the detail pixels (peak: the scan's).
    error_split : dict
        ``samples_psnr_db`` (the measured spectra at the open pixels against the scan's
        there) and ``rank1_from_scan_psnr_db`` (rank-1 fed with the scan's own spectra at
        the open pixels, after the affine fit): see :class:`MaskRun`.

    Examples
    --------
    >>> scores, detail, split = frame_scores(frame, reference, valid, detail)  # doctest: +SKIP
    """
    peak = float(reference[valid].max())
    rows, cols = np.nonzero(frame.mask)
    at_samples = reference[rows, cols].astype(np.float64)
    from_scan = rank1_cube(frame.guide_slm, frame.labels, frame.mask, np.nan_to_num(at_samples))
    error_split = {
        "samples_psnr_db": psnr(at_samples, frame.spectra, valid=valid[rows, cols], peak=peak),
        "rank1_from_scan_psnr_db": psnr(reference, from_scan, valid=valid, affine=True),
    }
    cubes = {"rank1": frame.rank1, "guided": frame.guided}
    scores = {method: Scores.of(cube, reference, valid) for method, cube in cubes.items()}
    detail_psnr = {
        method: psnr(reference, cube, valid=detail, peak=peak) for method, cube in cubes.items()
    }
    return scores, detail_psnr, error_split
