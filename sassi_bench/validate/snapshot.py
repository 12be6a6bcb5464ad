"""Scoring SASSI snapshots against a scan: the result types of the snapshot validation,
its scores (PSNR raw and after an affine fit, SSIM, spectral angle, per-band and detail PSNR,
and where the error comes from), and its inputs on disk (a scan cube, a user's mask).

Pure functions on arrays and files; :func:`sassi_bench.workflows.snapshot_validation.run_snapshot`
captures and reconstructs the snapshots and scores them here.

Scores are summed over blocks of rows (and SSIM band by band), reading the reconstructions
from their factored forms (:class:`~sassi_bench.snapshot.Rank1Cube`,
:class:`~sassi_bench.snapshot.LowRankCube`) a block at a time, so no dense reconstruction and
no float64 copy of a cube is made: at the prototype's scale (1080 x 1920 x 68 bins, 564 MB a
float32 cube) scoring holds the scan and a block, not a cube's worth per reconstruction.
The figures are those of
:mod:`sassi_bench.snapshot.metrics` on the whole cube (the same float64 sums, added in
another order).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from datetime import UTC, datetime
from functools import cached_property
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle import CalibrationBundle, MaskSpacing, QualityCheck
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot import (
    FrameReconstruction,
    LowRankCube,
    Rank1Cube,
    check_mask,
    psnr,
    rank1_factors,
)
from sassi_bench.spectra.angles import spectral_angle_deg
from sassi_bench.spectra.cube_io import units_label

__all__ = [
    "Estimate",
    "MaskRun",
    "ScanReference",
    "Scores",
    "SnapshotValidation",
    "cube_psnr",
    "detail_pixels",
    "frame_scores",
    "load_mask",
    "load_scan_cube",
    "warp_cube",
]


class ScanReference(NamedTuple):
    """The reference a snapshot is scored against: a scan cube on the SLM grid."""

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
    Not run here (it needs a scan or a procedure's result)::

        mask = load_mask("mask.npy", bundle.mask_spacing())
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
    Not run here (it needs a scan or a procedure's result)::

        reference = load_scan_cube("scan.nc", load(rig="sim"))
        reference.cube.shape, reference.units
        # ((400, 640, 68), 'W/(sr m^2 nm)')
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


#: A reconstructed cube: dense (H, W, B), or in a snapshot's factored form.
Estimate = NDArray[np.floating] | Rank1Cube | LowRankCube

#: Rows of the SLM grid scored at once.
_BLOCK_ROWS = 32


def _rows(cube: Estimate, start: int, stop: int) -> NDArray:
    """Rows ``start:stop`` of a cube, dense (rows, W, B)."""
    if isinstance(cube, np.ndarray):
        return cube[start:stop]
    width = cube.shape[1]
    rows = np.repeat(np.arange(start, stop), width)
    cols = np.tile(np.arange(width), stop - start)
    return cube.at(rows, cols).reshape(stop - start, width, -1)


def _band(cube: Estimate, index: int) -> NDArray:
    """Band ``index`` of a cube, (H, W)."""
    return cube[..., index] if isinstance(cube, np.ndarray) else cube.band(index)


def _pixels(cube: Estimate, reference: NDArray, where: NDArray[np.bool_]):
    """The scored pixels' spectra of both cubes, float64 (n, B), a block of rows at a time."""
    for start in range(0, where.shape[0], _BLOCK_ROWS):
        stop = min(start + _BLOCK_ROWS, where.shape[0])
        keep = where[start:stop]
        if keep.any():
            yield (
                np.asarray(reference[start:stop][keep], dtype=np.float64),
                np.asarray(_rows(cube, start, stop)[keep], dtype=np.float64),
            )


def _check(estimate: Estimate, reference: NDArray, where: NDArray[np.bool_]) -> None:
    fix = "score a cube of the scan's shape over a mask of its pixels with at least one True"
    if tuple(estimate.shape) != tuple(reference.shape) or where.shape != reference.shape[:2]:
        raise ProcedureError(
            step_error(
                "snapshot scores",
                f"the estimate is {tuple(estimate.shape)}, the reference "
                f"{tuple(reference.shape)} and the mask {where.shape}",
                fix,
            )
        )
    if not where.any():
        raise ProcedureError(step_error("snapshot scores", "the mask selects no pixel", fix))


def _db(mse: NDArray | float, peak: float) -> NDArray[np.float64]:
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(peak**2 / np.asarray(mse, dtype=np.float64))


@dataclass(frozen=True)
class _Sums:
    """One pass over the scored pixels: what PSNR, its affine fit and the angle need."""

    pixels: int
    peak: float
    squared_error: NDArray[np.float64]  # per band
    mean_estimate: float
    mean_reference: float
    angle_sum: float
    angles: int

    @classmethod
    def of(cls, estimate: Estimate, reference: NDArray, where: NDArray[np.bool_]) -> _Sums:
        pixels, peak, angle_sum, angles = 0, -np.inf, 0.0, 0
        error = np.zeros(reference.shape[2])
        total_e = total_r = 0.0
        for ref, est in _pixels(estimate, reference, where):
            pixels += ref.shape[0]
            peak = max(peak, float(ref.max()))
            error += np.sum((est - ref) ** 2, axis=0)
            total_e += float(est.sum())
            total_r += float(ref.sum())
            angle = spectral_angle_deg(ref, est)
            finite = np.isfinite(angle)
            angle_sum += float(angle[finite].sum())
            angles += int(finite.sum())
        values = pixels * reference.shape[2]
        return cls(pixels, peak, error, total_e / values, total_r / values, angle_sum, angles)

    def affine_psnr(self, estimate: Estimate, reference: NDArray, where, peak: float) -> float:
        """PSNR after the one least-squares ``a * estimate + b`` for the cube (two more
        passes: the fit about the means, then its error)."""
        variance = covariance = 0.0
        for ref, est in _pixels(estimate, reference, where):
            centred = est - self.mean_estimate
            variance += float(np.sum(centred * centred))
            covariance += float(np.sum(centred * (ref - self.mean_reference)))
        a = covariance / variance if variance > 0 else 0.0
        b = self.mean_reference - a * self.mean_estimate
        error = 0.0
        for ref, est in _pixels(estimate, reference, where):
            error += float(np.sum((a * est + b - ref) ** 2))
        return float(_db(error / (self.pixels * reference.shape[2]), peak))


def _ssim(estimate: Estimate, reference: NDArray, valid: NDArray[np.bool_]) -> float:
    """Mean SSIM over the scored pixels' bounding box (unscored pixels set to the
    reference), band by band: scikit-image's per channel, 7 x 7 windows, ``data_range`` the
    box's max minus min (as :func:`sassi_bench.snapshot.ssim` on the box)."""
    from skimage.metrics import structural_similarity

    rows, cols = np.nonzero(valid)
    box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
    ref_box = reference[box]
    span = float(ref_box.max() - ref_box.min()) or 1.0
    inside = valid[box]
    values = []
    for index in range(reference.shape[2]):
        ref = np.asarray(ref_box[..., index], dtype=np.float64)
        est = np.where(inside, _band(estimate, index)[box], ref_box[..., index])
        values.append(
            structural_similarity(ref, est.astype(np.float64), channel_axis=None, data_range=span)
        )
    return float(np.mean(values))


@dataclass(frozen=True)
class Scores:
    """A reconstruction against the reference, over the scored pixels."""

    psnr_db: float
    psnr_affine_db: float
    ssim: float
    spectral_angle_deg: float
    band_psnr_db: NDArray[np.float64]

    @classmethod
    def of(cls, estimate: Estimate, reference: NDArray, valid: NDArray[np.bool_]) -> Scores:
        """PSNR (raw, and after one affine fit for the cube), SSIM (over the scored
        pixels' bounding box, unscored pixels set to the reference), mean spectral angle
        and per-band PSNR; the peak is the reference's maximum over the scored pixels.

        ``estimate`` is a dense cube or a snapshot's factored one; it is read a block of
        rows (SSIM: a band) at a time.

        Examples
        --------
        >>> from sassi_bench.snapshot import psnr
        >>> rng = np.random.default_rng(0)
        >>> ref = rng.uniform(1, 2, (12, 10, 3)).astype(np.float32)
        >>> est = 0.5 * ref + 0.25 + rng.normal(0, 0.01, ref.shape).astype(np.float32)
        >>> s = Scores.of(est, ref, np.ones((12, 10), bool))
        >>> round(s.psnr_db, 9) == round(psnr(ref, est), 9), round(s.psnr_affine_db, 1)
        (True, 40.2)
        """
        valid = np.asarray(valid, dtype=bool)
        _check(estimate, reference, valid)
        sums = _Sums.of(estimate, reference, valid)
        bands = reference.shape[2]
        return cls(
            float(_db(sums.squared_error.sum() / (sums.pixels * bands), sums.peak)),
            sums.affine_psnr(estimate, reference, valid, sums.peak),
            _ssim(estimate, reference, valid),
            sums.angle_sum / sums.angles if sums.angles else float("nan"),
            _db(sums.squared_error / sums.pixels, sums.peak),
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "psnr_db": self.psnr_db,
            "psnr_affine_db": self.psnr_affine_db,
            "ssim": self.ssim,
            "spectral_angle_deg": self.spectral_angle_deg,
            "band_psnr_db": self.band_psnr_db.tolist(),
        }


def cube_psnr(
    estimate: Estimate,
    reference: NDArray,
    where: NDArray[np.bool_],
    *,
    peak: float | None = None,
    affine: bool = False,
) -> float:
    """PSNR of ``estimate`` over the pixels ``where``, block by block (see :class:`Scores`);
    ``peak`` defaults to the reference's maximum there.

    Examples
    --------
    >>> ref = np.ones((4, 4, 2), np.float32)
    >>> round(cube_psnr(0.9 * ref, ref, np.ones((4, 4), bool)), 3)  # MSE 0.01, peak 1
    20.0
    """
    where = np.asarray(where, dtype=bool)
    _check(estimate, reference, where)
    sums = _Sums.of(estimate, reference, where)
    top = sums.peak if peak is None else float(peak)
    if affine:
        return sums.affine_psnr(estimate, reference, where, top)
    return float(_db(sums.squared_error.sum() / (sums.pixels * reference.shape[2]), top))


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
    rank1_factored: Rank1Cube
    guided_factored: LowRankCube
    scores: dict[str, Scores]
    detail_psnr_db: dict[str, float]
    error_split: dict[str, float]
    sessions: list[str]
    exposure_s: float
    low_light: float = 1.0

    @cached_property
    def rank1(self) -> NDArray[np.float32]:
        """(H, W, B) float32 rank-1 cube, made on first use (the report draws the first
        snapshot's; the scores read the factored form)."""
        return self.rank1_factored.dense()

    @cached_property
    def guided(self) -> NDArray[np.float32]:
        """(H, W, B) float32 guided-filter cube, made on first use."""
        return self.guided_factored.dense()


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
    Not run here (it needs a scan or a procedure's result)::

        scores, detail, split = frame_scores(frame, reference, valid, detail)
    """
    peak = max(
        float(reference[start : start + _BLOCK_ROWS][valid[start : start + _BLOCK_ROWS]].max())
        for start in range(0, valid.shape[0], _BLOCK_ROWS)
        if valid[start : start + _BLOCK_ROWS].any()
    )
    rows, cols = np.nonzero(frame.mask)
    at_samples = reference[rows, cols].astype(np.float64)
    from_scan = rank1_factors(frame.guide_slm, frame.labels, frame.mask, np.nan_to_num(at_samples))
    error_split = {
        "samples_psnr_db": psnr(at_samples, frame.spectra, valid=valid[rows, cols], peak=peak),
        "rank1_from_scan_psnr_db": cube_psnr(from_scan, reference, valid, affine=True),
    }
    cubes = {"rank1": frame.rank1_factored, "guided": frame.guided_factored}
    scores = {method: Scores.of(cube, reference, valid) for method, cube in cubes.items()}
    detail_psnr = {
        method: cube_psnr(cube, reference, detail, peak=peak) for method, cube in cubes.items()
    }
    return scores, detail_psnr, error_split
