"""Offset removal: the smooth background under every frame, from pixels outside streaks.

Closed SLM pixels still leak ``1/contrast`` of the light, which lays a smooth background
(plus the camera's dark level) under every frame. The streak footprints of the open
pixels are predicted from the mask and the bundle; the background is estimated from
every other pixel (block medians, holes filled, then a cubic spline surface) and
subtracted. No all-closed frame is needed, so it works while the scene moves.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import BSpline, RectBivariateSpline

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra import _kernels, _offset_kernels
from sassi_bench.spectra.geometry import StreakGeometry

__all__ = ["Background", "estimate_background", "footprint_rectangles", "streak_footprint"]


def footprint_rectangles(
    geometry: StreakGeometry,
    shape: tuple[int, int],
    reach_sigmas: float = 3.0,
    margin_px: float = 3.0,
) -> tuple[NDArray[np.intp], NDArray[np.intp], NDArray[np.intp], NDArray[np.intp]]:
    """The rectangle each open pixel's light can reach: ``top, bottom, left, right``.

    Each open pixel's streak is covered from its first bin's left edge to its last bin's
    right edge (the bundle's bins, 400-700 nm), widened by ``margin_px`` for light just
    outside the band and by ``reach_sigmas`` blur sigmas of the bin at each end;
    vertically by ``reach_sigmas`` of the widest blur. Bounds are clipped to the camera
    ``shape`` (H, W); ``bottom`` and ``right`` are exclusive.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0]), np.array([0]), np.array([[10.0]]),
    ...                      np.array([[20.0]]), np.array([[5.0]]), np.array([1.0]), guard=0)
    >>> [int(b[0]) for b in footprint_rectangles(geo, (12, 30), 1, 0)]
    [4, 7, 9, 22]
    """
    h, w = shape
    core = geometry.core
    first, last = core.start, core.stop - 1
    reach_y = reach_sigmas * geometry.sigma.max()
    left = geometry.x_left[:, first] - margin_px - reach_sigmas * geometry.sigma[first]
    right = geometry.x_right[:, last] + margin_px + reach_sigmas * geometry.sigma[last]
    x0 = np.clip(np.floor(left), 0, w).astype(np.intp)
    x1 = np.clip(np.ceil(right) + 1, 0, w).astype(np.intp)
    y0 = np.clip(np.floor(geometry.y[:, core].min(axis=1) - reach_y), 0, h).astype(np.intp)
    y1 = np.clip(np.ceil(geometry.y[:, core].max(axis=1) + reach_y) + 1, 0, h).astype(np.intp)
    return y0, y1, x0, x1


def streak_footprint(
    geometry: StreakGeometry,
    shape: tuple[int, int],
    reach_sigmas: float = 3.0,
    margin_px: float = 3.0,
) -> NDArray[np.bool_]:
    """Camera pixels that light of the open pixels can reach (True), as one mask: the
    union of their :func:`footprint_rectangles`.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0]), np.array([0]), np.array([[10.0]]),
    ...                      np.array([[20.0]]), np.array([[5.0]]), np.array([1.0]), guard=0)
    >>> streak_footprint(geo, (12, 30), reach_sigmas=1, margin_px=0).sum(axis=1)[3:8].tolist()
    [0, 13, 13, 13, 0]
    """
    footprint = np.zeros(shape, dtype=np.bool_)
    _kernels.paint_rectangles(
        *footprint_rectangles(geometry, shape, reach_sigmas, margin_px), footprint
    )
    return footprint


def _extend(centres, values, first: float, last: float, axis: int):
    """Add linearly extrapolated samples at ``first`` and ``last`` along ``axis`` (where
    they lie outside the block centres)."""
    if centres.size < 2:
        return centres, values
    v = np.moveaxis(values, axis, 0)
    parts, points = [v], [centres]
    if first < centres[0]:
        lo = v[0] + (v[0] - v[1]) * (centres[0] - first) / (centres[1] - centres[0])
        parts.insert(0, lo[None])
        points.insert(0, [first])
    if last > centres[-1]:
        hi = v[-1] + (v[-1] - v[-2]) * (last - centres[-1]) / (centres[-1] - centres[-2])
        parts.append(hi[None])
        points.append([last])
    return np.concatenate(points), np.moveaxis(np.concatenate(parts), 0, axis)


@dataclass(frozen=True)
class Background:
    """A background estimate and how well it fits the pixels it was estimated from."""

    image: NDArray[np.float64]
    residual_rms: float
    free_fraction: float


def estimate_background(
    frame: ArrayLike, footprint: ArrayLike, block: tuple[int, int] = (8, 16), min_free: float = 0.05
) -> Background:
    """Smooth background of a frame from the pixels outside the streak footprint.

    The median of the free pixels of every block; blocks with too few free pixels are
    filled from the known blocks along their block row and column, the nearer weighing
    more; then an interpolating cubic spline surface through the block centres, extended
    linearly to the frame's edges.

    Under a dense snapshot most free pixels lie in thin bands between the streaks' rows;
    a block with 5 % free pixels (6 of 8 x 16) still gives a median there, where the
    former 20 % threshold left those blocks to interpolation across the streaks. On the
    sim rig (ColorChecker, halogen, pinholes at the bundle's spacing: 18 % of the window
    free) the median error under the streaks against the frame with the SLM closed went
    from 90 to 52 ADU on a leakage of 1100 ADU, in 11 ms instead of 0.4 s. Leakage changes
    across the streaks (the scene's edges) are not seen by any estimate from the free
    pixels alone: the 95th percentile error stays near 900 ADU there.

    Parameters
    ----------
    frame
        Raw frame (H, W).
    footprint
        Pixels to ignore (streaks), (H, W) bool.
    block
        Block size (rows, columns) of the median grid.
    min_free
        Blocks with less than this fraction of their pixels free are interpolated instead.

    Returns
    -------
    Background

    Examples
    --------
    >>> frame = np.add.outer(np.arange(32.0), np.arange(64.0))  # a plane
    >>> streaks = np.zeros((32, 64), bool); streaks[:, 16:40] = True
    >>> frame[streaks] += 1000.0
    >>> estimate = estimate_background(frame, streaks, block=(8, 8))
    >>> bool(np.abs(estimate.image - np.add.outer(np.arange(32.0), np.arange(64.0))).max() < 1e-6)
    True
    """
    data = np.asarray(frame)
    if data.dtype.kind not in "iuf" or data.dtype.itemsize > 8:
        data = data.astype(np.float64)
    data = np.ascontiguousarray(data)
    mask = np.ascontiguousarray(footprint, dtype=bool)
    h, w = data.shape
    by, bx = block
    ny, nx = -(-h // by), -(-w // bx)
    medians = np.empty((ny, nx))
    free = np.empty((ny, nx))
    _offset_kernels.block_medians(data, mask, by, bx, float(min_free), medians, free)
    if not (free >= min_free).any():
        raise ProcedureError(
            step_error(
                "offset removal",
                "the streaks cover the whole frame, leaving no background pixels",
                "open fewer SLM pixels per frame (a wider pinhole pitch)",
            )
        )
    while not np.isfinite(medians).all():  # twice at most: each pass fills some rows
        _offset_kernels.fill_holes(medians, by, bx)
    cy = (np.arange(ny) + 0.5) * by - 0.5
    cx = (np.arange(nx) + 0.5) * bx - 0.5
    # Extend the grid linearly to the frame's edges so the surface is not clamped there.
    cy, medians = _extend(cy, medians, 0, h - 1, axis=0)
    cx, medians = _extend(cx, medians, 0, w - 1, axis=1)
    image = _spline_surface(cy, cx, medians, h, w)
    total, count = _offset_kernels.squared_residual(data, mask, image)
    return Background(image, float(np.sqrt(total / count)), count / (h * w))


def _spline_surface(cy, cx, values, h: int, w: int) -> NDArray[np.float64]:
    """The interpolating cubic spline through ``values`` at ``(cy, cx)``, on every pixel.

    Evaluated as ``rows @ coefficients @ columns.T`` with the splines' sparse design
    matrices (four nonzeros a row): a few ms at 729 x 2048 where ``RectBivariateSpline``'s
    own grid evaluation took 0.23 s.
    """
    kx, ky = min(3, cy.size - 1), min(3, cx.size - 1)
    spline = RectBivariateSpline(cy, cx, values, kx=kx, ky=ky)
    if kx < 1 or ky < 1:
        return spline(np.arange(h), np.arange(w))
    tx, ty, coefficients = spline.tck
    coefficients = coefficients.reshape(tx.size - kx - 1, ty.size - ky - 1)
    rows = BSpline.design_matrix(np.arange(h, dtype=np.float64), tx, kx)
    columns = BSpline.design_matrix(np.arange(w, dtype=np.float64), ty, ky)
    return np.ascontiguousarray(rows @ (columns @ coefficients.T).T)
