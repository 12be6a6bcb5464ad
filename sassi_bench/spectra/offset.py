"""Offset removal: the smooth background under every frame, from pixels outside streaks.

Closed SLM pixels still leak ``1/contrast`` of the light, which lays a smooth background
(plus the camera's dark level) under every frame. The streak footprints of the open
pixels are predicted from the mask and the bundle; the background is estimated from
every other pixel (block medians, holes filled, then a cubic spline surface) and
subtracted. No all-closed frame is needed, so it works while the scene moves.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import BSpline, RectBivariateSpline, make_interp_spline
from scipy.sparse import csr_array

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.maths.banded import band_lu, band_lu_solve
from sassi_bench.spectra import _kernels, _offset_kernels
from sassi_bench.spectra.geometry import StreakGeometry

__all__ = [
    "Background",
    "BlockBackground",
    "block_values",
    "estimate_background",
    "fill_block_grid",
    "first_block_estimate",
    "footprint_rectangles",
    "streak_footprint",
]


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
    left = geometry.x_left[:, first] - margin_px - reach_sigmas * geometry.sigma[:, first]
    right = geometry.x_right[:, last] + margin_px + reach_sigmas * geometry.sigma[:, last]
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
    a block with 5 % free pixels (6 of 8 x 16) still gives a median there, where a higher
    threshold leaves those blocks to interpolation across the streaks and the error under
    the streaks grows (``docs/notes/2026-12-01-measured-in-code-comments.md``). Leakage
    changes across the streaks (the scene's edges) are not seen by any estimate from the
    free pixels alone.

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
    matrices (four nonzeros a row), cheaper than ``RectBivariateSpline``'s own grid
    evaluation (``docs/notes/2026-12-01-measured-in-code-comments.md``).
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


@dataclass(frozen=True)
class _Axis:
    """The interpolating spline along one axis of a block lattice: its degree, the banded
    LU factors of its collocation matrix (values at the extended block centres ->
    coefficients; :func:`~sassi_bench.maths.banded.band_lu`, bandwidth ``p``) and, for
    every pixel, the first of its ``degree + 1`` basis functions and their values."""

    degree: int
    lu: NDArray[np.float64]
    p: int
    pivots: NDArray[np.intp]
    index: NDArray[np.int64]
    basis: NDArray[np.float64]
    design: object  # the pixels' sparse basis matrix (dense evaluation)
    first: bool  # an extrapolated sample was added before the first block centre
    last: bool


@lru_cache(maxsize=16)
def _axis(pixels: int, block: int) -> _Axis:
    """The spline axis of ``pixels`` pixels in blocks of ``block`` (see
    :func:`estimate_background`: block centres, extended linearly to the edges)."""
    count = -(-pixels // block)
    centres = (np.arange(count) + 0.5) * block - 0.5
    points = centres
    first = last = False
    if count >= 2:
        first, last = bool(centres[0] > 0), bool(pixels - 1 > centres[-1])
        points = np.concatenate([[0.0] if first else [], centres, [pixels - 1.0] if last else []])
    degree = min(3, points.size - 1)
    x = np.arange(pixels, dtype=np.float64)
    if degree == 0:  # one block: constant
        ones = np.ones((pixels, 1))
        design = csr_array(ones)
        return _Axis(
            0, np.ones((1, 1)), 0, np.zeros(1, np.intp), np.zeros(pixels, np.int64), ones,
            design, first, last,
        )  # fmt: skip
    knots = make_interp_spline(points, np.zeros(points.size), k=degree).t
    collocation = BSpline.design_matrix(points, knots, degree).toarray()
    design = BSpline.design_matrix(np.clip(x, points[0], points[-1]), knots, degree).tocsr()
    design.sort_indices()
    index = design.indices.reshape(pixels, degree + 1)[:, 0].astype(np.int64)
    basis = design.data.reshape(pixels, degree + 1).copy()
    rows, cols = np.nonzero(collocation)
    p = int(max((rows - cols).max(), (cols - rows).max()))
    size = collocation.shape[0]
    lu = np.zeros((size, 3 * p + 1))
    lu[rows, cols - rows + p] = collocation[rows, cols]
    pivots = np.empty(size, np.intp)
    band_lu(lu, size, p, pivots)
    for array in (lu, pivots, index, basis):
        array.flags.writeable = False
    return _Axis(degree, lu, p, pivots, index, basis, design, first, last)


def _extended(values: NDArray[np.float64], axis: _Axis, block: int, along: int):
    """``values`` with the linear extrapolations to the edges of :func:`_extend`."""
    v = np.moveaxis(values, along, 0)
    parts = [v]
    if axis.first:  # at pixel 0, block centres at (i + 0.5) * block - 0.5
        parts.insert(0, (v[0] + (v[0] - v[1]) * ((block - 1) / 2) / block)[None])
    if axis.last:
        pixels = axis.index.size
        last_centre = (v.shape[0] - 0.5) * block - 0.5
        parts.append((v[-1] + (v[-1] - v[-2]) * (pixels - 1 - last_centre) / block)[None])
    return np.moveaxis(np.concatenate(parts), 0, along)


def fill_block_grid(values: NDArray[np.float64], block: tuple[int, int]) -> NDArray[np.float64]:
    """A copy of a block grid with its NaN filled from the known blocks along its rows and
    columns (as :func:`estimate_background` fills blocks with too few free pixels).

    Examples
    --------
    >>> fill_block_grid(np.array([[1.0, np.nan, 3.0]]), (8, 16)).tolist()
    [[1.0, 2.0, 3.0]]
    """
    filled = np.array(values, dtype=np.float64)
    if not np.isfinite(filled).any():
        raise ProcedureError(
            step_error(
                "offset removal",
                "no block of the frame gave a background value",
                "open fewer SLM pixels per frame (a wider pinhole pitch)",
            )
        )
    while not np.isfinite(filled).all():  # twice at most: each pass fills some rows
        _offset_kernels.fill_holes(filled, block[0], block[1])
    return filled


@dataclass(frozen=True)
class BlockBackground:
    """A smooth background of a camera window: one value per block of a fixed lattice
    (the blocks' medians) and the interpolating cubic spline surface through them, as
    :func:`estimate_background` builds it, kept as coefficients: the extraction evaluates
    it at the streaks' pixels only (the whole ``image`` is made on demand).

    Attributes
    ----------
    shape
        The window (H, W).
    block
        Block (rows, columns).
    values
        (ceil(H / rows), ceil(W / columns)) finite block values.

    Examples
    --------
    >>> plane = np.add.outer(np.arange(40.0), 2 * np.arange(64.0))
    >>> grid = plane.reshape(5, 8, 4, 16).mean(axis=(1, 3))  # block means of a plane
    >>> background = BlockBackground.from_values(grid, (40, 64), (8, 16))
    >>> bool(np.allclose(background.image, plane))
    True
    """

    shape: tuple[int, int]
    block: tuple[int, int]
    values: NDArray[np.float64]

    @classmethod
    def from_values(
        cls, values: ArrayLike, shape: tuple[int, int], block: tuple[int, int]
    ) -> BlockBackground:
        """The surface through finite block ``values`` (:func:`fill_block_grid` first when
        some are NaN)."""
        shape = (int(shape[0]), int(shape[1]))
        block = (int(block[0]), int(block[1]))
        grid = np.array(values, dtype=np.float64)  # a copy: the caller may refine its grid
        expected = (-(-shape[0] // block[0]), -(-shape[1] // block[1]))
        if grid.shape != expected:
            raise ProcedureError(
                step_error(
                    "offset removal",
                    f"a background grid of shape {grid.shape} for a {shape[0]} x {shape[1]} "
                    f"window in {block[0]} x {block[1]} blocks (expected {expected})",
                    "pass the background of a frame of the same camera window and blocks",
                )
            )
        if not np.isfinite(grid).all():
            grid = fill_block_grid(grid, block)
        return cls(shape, block, grid)

    @cached_property
    def _axes(self) -> tuple[_Axis, _Axis]:
        return _axis(self.shape[0], self.block[0]), _axis(self.shape[1], self.block[1])

    @cached_property
    def coefficients(self) -> NDArray[np.float64]:
        """The tensor spline's coefficients (rows' basis, columns' basis)."""
        rows, columns = self._axes
        values = _extended(self.values, rows, self.block[0], 0)
        values = _extended(values, columns, self.block[1], 1)
        # Interpolation along the rows, then along the columns: two banded solves (no
        # BLAS, whose threads spin against the video pipeline's other thread).
        band_lu_solve(rows.lu, values.shape[0], rows.p, rows.pivots, values)
        values = np.ascontiguousarray(values.T)
        band_lu_solve(columns.lu, values.shape[0], columns.p, columns.pivots, values)
        return np.ascontiguousarray(values.T)

    def kernel_arrays(self):
        """``coefficients, row_index, row_basis, col_index, col_basis`` for the compiled
        loops that evaluate the surface at chosen pixels:
        ``sum_p sum_q C[row_index[r] + p, col_index[c] + q] row_basis[r, p] col_basis[c, q]``.
        """
        rows, columns = self._axes
        return self.coefficients, rows.index, rows.basis, columns.index, columns.basis

    @cached_property
    def image(self) -> NDArray[np.float64]:
        """The surface on every pixel of the window, (H, W) (made on first use)."""
        rows, columns = self._axes
        coefficients = self.coefficients
        return np.ascontiguousarray(rows.design @ (columns.design @ coefficients.T).T)


def block_values(
    image: NDArray[np.floating],
    block: tuple[int, int],
    footprint: NDArray[np.bool_] | None = None,
    min_free: float = 0.05,
) -> NDArray[np.float64]:
    """The median of every block of ``image`` outside ``footprint`` (all pixels when None),
    NaN where less than ``min_free`` of a block's pixels are free.

    Examples
    --------
    >>> block_values(np.arange(32.0).reshape(4, 8), (2, 4)).tolist()
    [[5.5, 9.5], [21.5, 25.5]]
    """
    data = np.asarray(image)
    if data.dtype.kind not in "iuf" or data.dtype.itemsize > 8 or not data.flags.c_contiguous:
        data = np.ascontiguousarray(data, dtype=np.float64)
    mask = np.zeros(data.shape, bool) if footprint is None else np.ascontiguousarray(footprint)
    by, bx = block
    medians = np.empty((-(-data.shape[0] // by), -(-data.shape[1] // bx)))
    free = np.empty_like(medians)
    _offset_kernels.block_medians(data, mask, by, bx, float(min_free), medians, free)
    return medians


def first_block_estimate(
    image: NDArray[np.floating],
    geometry: StreakGeometry,
    block: tuple[int, int],
    wanted: NDArray[np.bool_],
    min_free: float = 0.05,
) -> NDArray[np.float64]:
    """The first background estimate of a window's ``wanted`` blocks, as
    :func:`estimate_background` makes it (block medians of the pixels outside the streaks'
    :func:`footprint_rectangles`), on the rectangle of blocks that holds them only; NaN
    elsewhere and where too few pixels are free.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0]), np.array([0]), np.array([[10.0]]),
    ...                      np.array([[20.0]]), np.array([[12.0]]), np.array([1.0]), guard=0)
    >>> wanted = np.zeros((3, 2), bool); wanted[1, 0] = True
    >>> first_block_estimate(np.ones((24, 32)), geo, (8, 16), wanted).tolist()
    [[nan, nan], [1.0, nan], [nan, nan]]
    """
    by, bx = block
    h, w = image.shape
    grid = np.full(wanted.shape, np.nan)
    rows, cols = np.nonzero(wanted)
    if rows.size == 0:
        return grid
    i0, i1, j0, j1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    r0, c0 = i0 * by, j0 * bx
    crop = image[r0 : min(h, i1 * by), c0 : min(w, j1 * bx)]
    top, bottom, left, right = footprint_rectangles(geometry, (h, w))
    footprint = np.zeros(crop.shape, dtype=np.bool_)
    _kernels.paint_rectangles(
        np.clip(top - r0, 0, crop.shape[0]), np.clip(bottom - r0, 0, crop.shape[0]),
        np.clip(left - c0, 0, crop.shape[1]), np.clip(right - c0, 0, crop.shape[1]), footprint,
    )  # fmt: skip
    values = block_values(crop, block, footprint, min_free)
    part = grid[i0:i1, j0:j1]
    inside = wanted[i0:i1, j0:j1]
    part[inside] = values[inside]
    return grid
