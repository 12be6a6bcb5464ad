"""Finding the 24 patches of a ColorChecker on the SLM grid.

The chart is a 6 x 4 grid of patches; a projective map from *chart coordinates* (column,
row of the patch grid, patch centres at integers) to SLM pixels ``(u, v)`` locates every
patch, including those that blend into the chart's frame (the black patch). The map comes
either from four clicked patch centres (:func:`grid_from_corners`) or from a detector
(:func:`detect_chart`) in the spirit of colour-checker-detection's segmentation method:
flat regions of a picture of the scene that look like squares of one size, fitted to a
grid whose orientation is chosen by comparing colours with the reference chart.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import product

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ProcedureError, step_error

__all__ = ["CHART_COLS", "CHART_ROWS", "ChartGrid", "detect_chart", "grid_from_corners"]

CHART_ROWS, CHART_COLS = 4, 6
#: Chart coordinates (column, row) of the patch centres the four corners name: patches
#: 1 (dark skin), 6 (bluish green), 24 (black) and 19 (white).
CORNER_PATCHES = np.array([[0.0, 0.0], [5.0, 0.0], [5.0, 3.0], [0.0, 3.0]])


class LocateError(ProcedureError):
    """The chart could not be found automatically."""


@dataclass(frozen=True)
class ChartGrid:
    """Where the chart's patches are on the SLM.

    Attributes
    ----------
    homography
        3x3 map from chart coordinates (column, row; patch centres at integers) to SLM
        ``(u, v)``.
    method
        ``"auto"`` or ``"corners"``.
    detected
        Patches the detector found as regions (24 for manual corners).
    """

    homography: NDArray[np.float64]
    method: str
    detected: int = CHART_ROWS * CHART_COLS

    def centres(self) -> NDArray[np.float64]:
        """SLM ``(u, v)`` of the 24 patch centres in reading order, (24, 2).

        Examples
        --------
        >>> grid = grid_from_corners([[10, 20], [60, 20], [60, 50], [10, 50]])
        >>> grid.centres()[[0, 5, 23]].tolist()
        [[10.0, 20.0], [60.0, 20.0], [60.0, 50.0]]
        """
        rows, cols = np.divmod(np.arange(CHART_ROWS * CHART_COLS), CHART_COLS)
        return _apply(self.homography, np.stack([cols, rows], axis=1).astype(np.float64))

    def to_slm(self, chart_points: ArrayLike) -> NDArray[np.float64]:
        """SLM ``(u, v)`` of chart coordinates (N, 2) (column, row).

        Examples
        --------
        >>> grid = grid_from_corners([[0, 0], [50, 0], [50, 30], [0, 30]])
        >>> grid.to_slm([[0.5, 0.5]]).tolist()
        [[5.0, 5.0]]
        """
        return _apply(self.homography, np.asarray(chart_points, dtype=np.float64).reshape(-1, 2))

    def labels(
        self, shape: tuple[int, int], origin: tuple[int, int] = (0, 0), interior: float = 0.5
    ) -> NDArray[np.intp]:
        """Patch index (0-23) of every pixel in a patch's interior, -1 elsewhere.

        Parameters
        ----------
        shape
            (rows, cols) of the image on the SLM grid.
        origin
            SLM (row, column) of the image's first pixel (an ROI's corner).
        interior
            Side of the measured square around each patch centre, as a fraction of the
            patch pitch (the patches themselves are about 0.8; edges are blurred).

        Examples
        --------
        >>> grid = grid_from_corners([[10, 10], [60, 10], [60, 40], [10, 40]])
        >>> lab = grid.labels((50, 70), interior=0.5)
        >>> int(lab[10, 10]), int(lab[40, 60]), int((lab == 0).sum())
        (0, 23, 25)
        """
        rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
        uv = np.stack([cols.ravel() + origin[1], rows.ravel() + origin[0]], axis=1)
        chart = _apply(np.linalg.inv(self.homography), uv.astype(np.float64))
        nearest = np.rint(chart)
        inside = np.all(np.abs(chart - nearest) <= interior / 2.0, axis=1)
        inside &= (nearest[:, 0] >= 0) & (nearest[:, 0] < CHART_COLS)
        inside &= (nearest[:, 1] >= 0) & (nearest[:, 1] < CHART_ROWS)
        index = (nearest[:, 1] * CHART_COLS + nearest[:, 0]).astype(np.intp)
        return np.where(inside, index, -1).reshape(shape)


def _apply(h: NDArray[np.float64], points: NDArray[np.float64]) -> NDArray[np.float64]:
    p = np.c_[points, np.ones(len(points))] @ np.asarray(h).T
    return p[:, :2] / p[:, 2:3]


def grid_from_corners(corners: ArrayLike) -> ChartGrid:
    """The chart from four SLM ``(u, v)`` patch centres: patches 1, 6, 24 and 19.

    That is dark skin, bluish green, black and white: the chart's corners in reading
    order, clockwise from the top left of the chart as printed.

    Examples
    --------
    >>> grid_from_corners([[0, 0], [50, 0], [50, 30], [0, 30]]).centres()[7].tolist()
    [10.0, 10.0]
    """
    import cv2

    pts = np.asarray(corners, dtype=np.float64)
    if pts.shape != (4, 2) or not np.all(np.isfinite(pts)):
        raise ProcedureError(
            step_error(
                "Macbeth patch corners",
                f"expected four (u, v) points, got an array of shape {pts.shape}",
                "give the SLM (u, v) centres of patches 1, 6, 24 and 19 (dark skin, bluish "
                "green, black, white), e.g. --corners u1 v1 u6 v6 u24 v24 u19 v19",
            )
        )
    d1, d2 = pts[2] - pts[0], pts[3] - pts[1]
    area = 0.5 * abs(d1[0] * d2[1] - d1[1] * d2[0])
    if area < 1.0:
        raise ProcedureError(
            step_error(
                "Macbeth patch corners",
                "the four points enclose no area",
                "give four distinct patch centres in the order 1, 6, 24, 19",
            )
        )
    h = cv2.getPerspectiveTransform(CORNER_PATCHES.astype(np.float32), pts.astype(np.float32))
    return ChartGrid(np.asarray(h, dtype=np.float64), "corners")


def _regions(rgb: NDArray[np.float64]):
    """Square-looking flat regions of one size: centres (N, 2) (u, v), areas, label image."""
    import cv2

    smooth = cv2.GaussianBlur(rgb.astype(np.float32), (0, 0), 1.5)
    grad = np.zeros(rgb.shape[:2], np.float32)
    for c in range(smooth.shape[2]):
        gx = cv2.Sobel(smooth[..., c], cv2.CV_32F, 1, 0, ksize=3)
        gy = cv2.Sobel(smooth[..., c], cv2.CV_32F, 0, 1, ksize=3)
        grad = np.maximum(grad, np.hypot(gx, gy))
    flat = (grad < 0.1 * np.percentile(grad, 99)).astype(np.uint8)
    flat = cv2.erode(flat, np.ones((3, 3), np.uint8), iterations=2)
    _, labels, stats, centroids = cv2.connectedComponentsWithStats(flat, connectivity=4)
    area = stats[1:, cv2.CC_STAT_AREA].astype(np.float64)
    w = stats[1:, cv2.CC_STAT_WIDTH].astype(np.float64)
    h = stats[1:, cv2.CC_STAT_HEIGHT].astype(np.float64)
    total = float(rgb.shape[0] * rgb.shape[1])
    keep = (area >= 2e-4 * total) & (area <= total / 30.0)
    keep &= (area / (w * h) >= 0.75) & (w / h >= 0.6) & (w / h <= 1 / 0.6)
    if keep.any():
        median = np.median(area[keep])
        keep &= (area >= 0.5 * median) & (area <= 2.0 * median)
    ids = np.flatnonzero(keep) + 1
    return centroids[ids], area[ids - 1], labels, ids


def _lattice(centres: NDArray[np.float64]) -> tuple[NDArray[np.intp], float]:
    """Integer lattice indices (N, 2) of roughly grid-placed points, and the pitch."""
    d = np.linalg.norm(centres[:, None] - centres[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    nearest = np.argmin(d, axis=1)
    pitch = float(np.median(d[np.arange(len(centres)), nearest]))
    vec = centres[nearest] - centres
    theta = np.arctan2(vec[:, 1], vec[:, 0])
    angle = np.arctan2(np.mean(np.sin(4 * theta)), np.mean(np.cos(4 * theta))) / 4.0
    rot = np.array([[np.cos(angle), np.sin(angle)], [-np.sin(angle), np.cos(angle)]])
    local = (centres - centres.mean(axis=0)) @ rot.T / pitch
    index = np.rint(local - local.min(axis=0)).astype(np.intp)
    misfit = np.abs(local - local.min(axis=0) - index).max()
    if misfit > 0.3 or len({tuple(i) for i in index}) < len(index):
        raise LocateError(f"the square regions do not form a grid (misfit {misfit:.2f} pitch)")
    return index, pitch


def _placements(index: NDArray[np.intp]):
    """Every way the lattice points can sit on the 6 x 4 chart: (N, 2) chart (col, row)."""
    for transpose, flip_c, flip_r in product((False, True), repeat=3):
        idx = index[:, ::-1] if transpose else index
        idx = idx * np.where([flip_c, flip_r], -1, 1)
        idx = idx - idx.min(axis=0)
        span = idx.max(axis=0)
        for dc in range(CHART_COLS - int(span[0])):
            for dr in range(CHART_ROWS - int(span[1])):
                yield idx + np.array([dc, dr])


def _log_chroma(rgb_linear: NDArray[np.float64]) -> NDArray[np.float64]:
    """Log colours with each channel's mean removed (grey world): light- and gain-free."""
    logs = np.log(np.clip(rgb_linear, 1e-4, None))
    return logs - logs.mean(axis=0)


def detect_chart(rgb: ArrayLike, reference_rgb: ArrayLike) -> ChartGrid:
    """Find the chart in a picture of the scene on the SLM grid.

    Parameters
    ----------
    rgb
        (H, W, 3) display-encoded sRGB picture, 0-1 (e.g.
        :func:`~sassi_bench.validate.colorimetry.cube_to_srgb` of the scanned cube).
    reference_rgb
        (24, 3) *linear* RGB of the reference patches, for the chart's orientation.

    Returns
    -------
    ChartGrid

    Raises
    ------
    LocateError
        If fewer than six patches are found or they do not form a grid.
    """
    import colour
    import cv2

    image = np.asarray(rgb, dtype=np.float64)
    centres, _, labels, ids = _regions(image)
    if len(centres) < 6:
        raise LocateError(
            step_error(
                "Macbeth patch detection",
                f"found {len(centres)} patch-like regions, need at least 6",
                "check the chart is in view and lit, or give the four corners (--corners)",
            )
        )
    index, _ = _lattice(centres)
    linear = colour.cctf_decoding(np.clip(image, 0, 1), function="sRGB")
    means = np.stack([linear[labels == i].mean(axis=0) for i in ids])
    measured = _log_chroma(means)
    reference = np.asarray(reference_rgb, dtype=np.float64)
    best = None
    for chart in _placements(index):
        patch = chart[:, 1] * CHART_COLS + chart[:, 0]
        cost = float(np.mean((measured - _log_chroma(reference[patch])) ** 2))
        if best is None or cost < best[0]:
            best = (cost, chart)
    assert best is not None
    h, _ = cv2.findHomography(best[1].astype(np.float64), centres.astype(np.float64), 0)
    if h is None:
        raise LocateError(
            step_error(
                "Macbeth patch detection",
                "the patch centres do not determine a projective map",
                "give the four corners (--corners)",
            )
        )
    return ChartGrid(np.asarray(h, dtype=np.float64), "auto", detected=len(centres))
