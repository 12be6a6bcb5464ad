"""Cells: the camera window of every (open pixel, bin), its sum, and the row unmixing.

For each open pixel and bin, the light is summed over the bin's columns (fractional end
columns) and over the rows nearer to this pixel's bin centre than to any other open pixel
of the same SLM column (its *cell*; at most +-3 sigma). At the standard 5 px vertical
pitch the blurred profiles of neighbours overlap, so the cell sums of one SLM column are
a banded mixture of the true amplitudes; the mixture is known from the bundle (Gaussian
integrals over the cells) and is solved per column and bin with one banded solve.

The layout of the cells depends only on the geometry, never on the frame, so it is built
once (:func:`cell_layout`) and applied to any image's column-cumulative sum
(:func:`column_cumsum`, :func:`cell_sums`). Cell sums are linear in the image, so the
sums of a background can be subtracted from those of a raw frame later.

The loops themselves are compiled (:mod:`sassi_bench.spectra._kernels`, numba) on first
use in a process, which takes a few seconds once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra import _kernels
from sassi_bench.spectra.geometry import StreakGeometry

__all__ = [
    "NEGLIGIBLE_COUPLING",
    "CellLayout",
    "cell_layout",
    "cell_sums",
    "column_cumsum",
    "coupling_reach",
    "unmix_rows",
]

#: Stacked neighbours that can put at most this fraction of their light into a cell are
#: left out of the row unmixing (:func:`coupling_reach`): two orders of magnitude under
#: the photon noise of a full-well pixel. At the default 5 px pitch that keeps one or two
#: neighbours for most bins and none where the blur is narrower than the cells.
NEGLIGIBLE_COUPLING = 1e-4


def column_cumsum(image: ArrayLike, out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Cumulative sum down the columns with a leading row of zeros, (H + 1, W) float64.

    ``out[r1, c] - out[r0, c]`` is the sum of rows ``r0 .. r1 - 1`` of column ``c``.
    Compiled, one row at a time: numpy's ``cumsum(axis=0)`` walks each column with a
    stride of a whole row and is about ten times slower on camera frames.

    Examples
    --------
    >>> column_cumsum(np.arange(6).reshape(3, 2))[:, 1].tolist()
    [0.0, 1.0, 4.0, 9.0]
    """
    image = np.asarray(image)
    if out is None:
        out = np.empty((image.shape[0] + 1, image.shape[1]))
    _kernels.column_cumsum(image, out)
    return out


@dataclass(frozen=True)
class CellLayout:
    """Where each (pixel, bin) cell lies on the camera, and how the pixels stack.

    Attributes
    ----------
    lo, hi
        The cell's continuous row bounds (pixel edges), (N, B').
    off
        Cells that leave the frame, (N, B').
    index
        (G, S) pixel index of the s-th pixel from the top of SLM column group g; -1 pads.
    x_left, x_right
        The bins' column bounds (the geometry's), (N, B').
    shape
        The camera (H, W).
    """

    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    off: NDArray[np.bool_]
    index: NDArray[np.intp]
    x_left: NDArray[np.float64]
    x_right: NDArray[np.float64]
    shape: tuple[int, int]

    @property
    def top(self) -> NDArray[np.intp]:
        """First camera row of each cell, clipped to the frame, (N, B')."""
        return np.clip(self.lo + 0.5, 0, self.shape[0]).astype(np.intp)

    @property
    def bottom(self) -> NDArray[np.intp]:
        """One past the last camera row of each cell, clipped to the frame, (N, B')."""
        return np.clip(self.hi + 0.5, 0, self.shape[0]).astype(np.intp)


def _floats(values: NDArray) -> NDArray[np.float64]:
    return np.ascontiguousarray(values, dtype=np.float64)


def cell_layout(geometry: StreakGeometry, shape: tuple[int, int]) -> CellLayout:
    """The cells of a frame's open pixels on a camera of ``shape`` (H, W).

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0, 5]), np.array([3, 3]), np.array([[10.0], [10.0]]),
    ...                      np.array([[11.0], [11.0]]), np.array([[4.0], [9.0]]),
    ...                      np.array([1.0]), guard=0)
    >>> layout = cell_layout(geo, (20, 30))
    >>> layout.top[:, 0].tolist(), layout.bottom[:, 0].tolist(), layout.index.tolist()
    ([1, 6], [6, 12], [[0, 1]])
    """
    h, w = shape
    geo = geometry
    n = geo.y.shape[0]
    # Pixels stacked in one SLM column, top to bottom: one row of `index` per column.
    order = np.lexsort((geo.y[:, geo.core].mean(axis=1), geo.cols))
    starts = np.flatnonzero(np.r_[True, geo.cols[order[1:]] != geo.cols[order[:-1]]])
    counts = np.diff(np.r_[starts, n])
    index = np.full((starts.size, int(counts.max(initial=0))), -1, dtype=np.intp)
    index[np.repeat(np.arange(starts.size), counts), np.arange(n) - np.repeat(starts, counts)] = (
        order
    )
    y, x_left, x_right = _floats(geo.y), _floats(geo.x_left), _floats(geo.x_right)
    lo, hi = np.empty_like(y), np.empty_like(y)
    off = np.empty(y.shape, dtype=np.bool_)
    sigma = _floats(geo.sigma)
    if not np.all(sigma > 0):
        raise ProcedureError(
            step_error(
                "spectrum extraction",
                f"the blur widths {sigma.min():.3g}..{sigma.max():.3g} px are not all positive",
                "load a bundle whose blur fit passed its checks (sassi-bench bundle verify)",
            )
        )
    bad = _kernels.cell_bounds(y, sigma, index, 3.0, h, w, x_left, x_right, lo, hi, off)
    if bad:
        raise ProcedureError(
            step_error(
                "spectrum extraction",
                f"{bad} (pixel, bin) positions of the streak geometry are not finite",
                "load a bundle whose dispersion fit passed its checks (sassi-bench bundle verify)",
            )
        )
    return CellLayout(lo, hi, off, index, x_left, x_right, (int(h), int(w)))


def cell_sums(cumulative: NDArray[np.float64], layout: CellLayout) -> NDArray[np.float64]:
    """Sum of each cell, (N, B'), from an image's :func:`column_cumsum`.

    Columns count with the fraction of ``[c - 0.5, c + 0.5]`` inside the bin.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0]), np.array([0]), np.array([[2.0]]),
    ...                      np.array([[4.0]]), np.array([[3.0]]), np.array([0.3]), guard=0)
    >>> cell_sums(column_cumsum(np.ones((8, 8))), cell_layout(geo, (8, 8))).tolist()
    [[4.0]]
    """
    out = np.empty_like(layout.lo)
    _kernels.cell_sums(
        _floats(cumulative), layout.x_left, layout.x_right, layout.lo, layout.hi, out
    )
    return out


def coupling_reach(
    layout: CellLayout, geometry: StreakGeometry, floor: float = NEGLIGIBLE_COUPLING
) -> NDArray[np.intp]:
    """Per bin, how many stacked neighbours away a pixel's light in a cell can exceed
    ``floor`` (a bound from the closest spacing of stacked pixels and the cells' extents).

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0, 5]), np.array([3, 3]), np.array([[10.0] * 2] * 2),
    ...                      np.array([[11.0] * 2] * 2), np.array([[4.0, 4.0], [9.0, 9.0]]),
    ...                      np.array([0.5, 2.0]), guard=0)
    >>> coupling_reach(cell_layout(geo, (20, 30)), geo).tolist()  # sharp bin, blurred bin
    [0, 1]
    """
    reach = np.empty(layout.lo.shape[1], dtype=np.intp)
    _kernels.coupling_reach(
        _floats(geometry.y),
        layout.lo,
        layout.hi,
        _floats(geometry.sigma.max(axis=0, initial=0.0)),
        layout.index,
        float(floor),
        geometry.profile.cdf_table,
        reach,
    )
    return reach


def unmix_rows(
    sums: NDArray[np.float64],
    layout: CellLayout,
    geometry: StreakGeometry,
    floor: float = NEGLIGIBLE_COUPLING,
) -> NDArray[np.float64]:
    """Amplitudes (N, B') of stacked pixels from their cell sums (banded solve per column
    and bin); neighbours farther than :func:`coupling_reach` are neglected.

    Each system ``A[s, s + d]`` (light of pixel ``s + d`` in cell ``s``, exact Gaussian
    integrals) is solved exactly: by elimination without pivoting where it is diagonally
    dominant (the usual case, and stable there), else by banded LU with partial pivoting,
    so a pitch finer than the blur is solved as reliably as the standard one.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0]), np.array([0]), np.array([[2.0]]),
    ...                      np.array([[4.0]]), np.array([[3.0]]), np.array([0.3]), guard=0)
    >>> layout = cell_layout(geo, (8, 8))
    >>> layout.lo.tolist(), layout.hi.tolist()  # the cell: rows 2 and 3
    ([[1.5]], [[3.5]])
    >>> # It holds Phi(0.5 / 0.3) - Phi(-1.5 / 0.3) = 0.9522 of the pixel's light.
    >>> unmix_rows(np.array([[0.9522]]), layout, geo).round(4).tolist()
    [[1.0]]
    """
    y, sigma = _floats(geometry.y), _floats(geometry.sigma)
    reach = coupling_reach(layout, geometry, floor)
    out = np.zeros_like(y)
    _kernels.unmix_rows(
        _floats(sums),
        y,
        layout.lo,
        layout.hi,
        sigma,
        layout.index,
        reach,
        geometry.profile.cdf_table,
        out,
    )
    return out
