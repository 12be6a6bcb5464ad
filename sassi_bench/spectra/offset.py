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
from scipy.interpolate import RectBivariateSpline, griddata

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra import _kernels
from sassi_bench.spectra.extract import StreakGeometry

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
    frame: ArrayLike, footprint: ArrayLike, block: tuple[int, int] = (8, 16), min_free: float = 0.2
) -> Background:
    """Smooth background of a frame from the pixels outside the streak footprint.

    Parameters
    ----------
    frame
        Raw frame (H, W).
    footprint
        Pixels to ignore (streaks), (H, W) bool.
    block
        Block size (rows, columns) of the median grid.
    min_free
        Blocks with less than this fraction of free pixels are interpolated instead.

    Returns
    -------
    Background
    """
    data = np.asarray(frame, dtype=np.float64)
    mask = np.asarray(footprint, dtype=bool)
    h, w = data.shape
    by, bx = block
    ny, nx = -(-h // by), -(-w // bx)
    padded = np.full((ny * by, nx * bx), np.nan)
    padded[:h, :w] = np.where(mask, np.nan, data)
    tiles = padded.reshape(ny, by, nx, bx).transpose(0, 2, 1, 3).reshape(ny, nx, by * bx)
    free = np.isfinite(tiles).mean(axis=2)
    if not (free >= min_free).any():
        raise ProcedureError(
            step_error(
                "offset removal",
                "the streaks cover the whole frame, leaving no background pixels",
                "open fewer SLM pixels per frame (a wider pinhole pitch)",
            )
        )
    usable = np.where(free[..., None] >= min_free, tiles, np.nan)
    medians = np.full((ny, nx), np.nan)
    enough = free >= min_free
    medians[enough] = np.nanmedian(usable[enough], axis=1)
    cy = (np.arange(ny) + 0.5) * by - 0.5
    cx = (np.arange(nx) + 0.5) * bx - 0.5
    gy, gx = np.meshgrid(cy, cx, indexing="ij")
    known = np.isfinite(medians)
    if not known.all():
        points = np.column_stack([gy[known], gx[known]])
        filled = griddata(points, medians[known], (gy, gx), method="linear")
        holes = ~np.isfinite(filled)
        filled[holes] = griddata(points, medians[known], (gy[holes], gx[holes]), method="nearest")
        medians = filled
    # Extend the grid linearly to the frame's edges so the surface is not clamped there.
    cy, medians = _extend(cy, medians, 0, h - 1, axis=0)
    cx, medians = _extend(cx, medians, 0, w - 1, axis=1)
    spline = RectBivariateSpline(cy, cx, medians, kx=min(3, cy.size - 1), ky=min(3, cx.size - 1))
    image = spline(np.arange(h), np.arange(w))
    residual = (data - image)[~mask]
    return Background(image, float(np.sqrt(np.mean(residual**2))), float((~mask).mean()))
