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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import solve_banded
from scipy.special import ndtr

from sassi_bench.spectra.geometry import StreakGeometry

__all__ = [
    "NEGLIGIBLE_COUPLING",
    "CellLayout",
    "cell_layout",
    "cell_sums",
    "column_cumsum",
    "unmix_rows",
]

#: Neighbour couplings below this fraction of a pixel's light are left out of the row
#: unmixing: at the default 5 px pitch that drops the second neighbours (about 2e-5) and
#: every coupling of bins whose blur is narrower than the cells, two orders of magnitude
#: under the photon noise of a full-well pixel, and it saves most Gaussian integrals.
NEGLIGIBLE_COUPLING = 1e-4


def column_cumsum(image: ArrayLike, out: NDArray[np.float64] | None = None) -> NDArray[np.float64]:
    """Cumulative sum down the columns with a leading row of zeros, (H + 1, W) float64.

    ``out[r1, c] - out[r0, c]`` is the sum of rows ``r0 .. r1 - 1`` of column ``c``.
    Computed one row at a time: numpy's ``cumsum(axis=0)`` walks each column with a
    stride of a whole row and is about ten times slower on camera frames (74 ms against
    7 ms for 2048 x 2048 here), while adding whole rows streams through memory.

    Examples
    --------
    >>> column_cumsum(np.arange(6).reshape(3, 2))[:, 1].tolist()
    [0.0, 1.0, 4.0, 9.0]
    """
    image = np.asarray(image)
    h, w = image.shape
    if out is None:
        out = np.empty((h + 1, w))
    out[0] = 0.0
    for r in range(h):  # rows, not pixels: each step adds a whole row
        np.add(out[r], image[r], out=out[r + 1])
    return out


@dataclass(frozen=True)
class CellLayout:
    """Where each (pixel, bin) cell lies on the camera, and how the pixels stack.

    Attributes
    ----------
    top, bottom
        First and one-past-last camera row of each cell, (N, B'), clipped to the frame.
    columns, weights
        Camera columns (N, B', span), clipped to the frame, and the fraction of each
        column inside the bin.
    lo, hi
        The cell's continuous row bounds (pixel edges), (N, B').
    off
        Cells that leave the frame, (N, B').
    index
        (G, S) pixel index of the s-th pixel from the top of SLM column group g; -1 pads.
    """

    top: NDArray[np.intp]
    bottom: NDArray[np.intp]
    columns: NDArray[np.intp]
    weights: NDArray[np.float64]
    lo: NDArray[np.float64]
    hi: NDArray[np.float64]
    off: NDArray[np.bool_]
    index: NDArray[np.intp]


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
    order = np.lexsort((geo.y[:, geo.core].mean(axis=1), geo.cols))
    same_up = np.zeros(n, dtype=bool)
    same_up[order[1:]] = geo.cols[order[1:]] == geo.cols[order[:-1]]
    same_down = np.zeros(n, dtype=bool)
    same_down[order[:-1]] = geo.cols[order[:-1]] == geo.cols[order[1:]]
    above = np.empty(n, dtype=np.intp)
    above[order[1:]] = order[:-1]
    above[order[0]] = order[0]
    below = np.empty(n, dtype=np.intp)
    below[order[:-1]] = order[1:]
    below[order[-1]] = order[-1]
    reach = 3.0 * geo.sigma[None, :]
    lo = np.where(same_up[:, None], (geo.y + geo.y[above]) / 2, -np.inf)
    hi = np.where(same_down[:, None], (geo.y + geo.y[below]) / 2, np.inf)
    lo = np.maximum(lo, geo.y - reach)
    hi = np.minimum(hi, geo.y + reach)
    # Rows whose upper edge lies in [lo, hi): neighbours share the rows between them.
    first_row = np.ceil(lo - 0.5).astype(np.intp)
    last_row = np.ceil(hi - 0.5).astype(np.intp) - 1
    first_col = np.floor(geo.x_left + 0.5).astype(np.intp)
    span = int(np.max(np.floor(geo.x_right + 0.5) - first_col)) + 1
    cols = first_col[..., None] + np.arange(span)
    # Fraction of each column [c - 0.5, c + 0.5] inside the bin (in place: these are the
    # largest arrays of the extraction).
    weights = cols + 0.5
    np.minimum(weights, geo.x_right[..., None], out=weights)
    weights -= np.maximum(cols - 0.5, geo.x_left[..., None])
    np.clip(weights, 0.0, 1.0, out=weights)
    off = (first_row < 0) | (last_row >= h) | (geo.x_left < -0.5) | (geo.x_right > w - 0.5)
    # Pixels stacked in one SLM column, top to bottom: one row of `index` per column.
    starts = np.flatnonzero(~same_up[order])
    counts = np.diff(np.r_[starts, n])
    index = np.full((starts.size, int(counts.max())), -1, dtype=np.intp)
    index[np.repeat(np.arange(starts.size), counts), np.arange(n) - np.repeat(starts, counts)] = (
        order
    )
    return CellLayout(
        top=np.clip(first_row, 0, h),
        bottom=np.clip(last_row + 1, 0, h),
        columns=np.clip(cols, 0, w - 1, out=cols),
        weights=weights,
        lo=first_row - 0.5,
        hi=last_row + 0.5,
        off=off,
        index=index,
    )


def cell_sums(cumulative: NDArray[np.float64], layout: CellLayout) -> NDArray[np.float64]:
    """Sum of each cell, (N, B'), from an image's :func:`column_cumsum`.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0]), np.array([0]), np.array([[2.0]]),
    ...                      np.array([[4.0]]), np.array([[3.0]]), np.array([0.3]), guard=0)
    >>> cell_sums(column_cumsum(np.ones((8, 8))), cell_layout(geo, (8, 8))).tolist()
    [[4.0]]
    """
    width = cumulative.shape[1]
    flat = cumulative.ravel()
    lower = np.take(flat, layout.bottom[..., None] * width + layout.columns)
    lower -= np.take(flat, layout.top[..., None] * width + layout.columns)
    return np.einsum("nbc,nbc->nb", lower, layout.weights)


def _solve_banded(bands: dict[int, NDArray], rhs: NDArray) -> NDArray:
    """Solve banded systems along the first axis of ``rhs`` (S, ...), one per trailing index.

    ``bands[d][i, ...]`` holds ``A[i, i + d]`` (zero where ``i + d`` leaves the system);
    ``bands`` and ``rhs`` are overwritten. Diagonally dominant systems (a pixel keeps more
    of its light in its cell than its neighbours put there together: the usual case) are
    eliminated without pivoting, which is stable for them, all systems at once with a loop
    over the S rows. That is several times faster than LAPACK's banded solver (gbsv),
    which pivots and spends most of its time in per-row call overhead at these small
    bandwidths (42 ms against 9 ms for 1300 systems of 216 rows, bandwidth 3). Other
    systems go to LAPACK, laid end to end as one block-diagonal banded system.
    """
    p = max(abs(d) for d in bands)
    if p == 0:
        return rhs / bands[0]
    if np.all(np.abs(bands[0]) > sum(np.abs(v) for d, v in bands.items() if d)):
        return _eliminate(bands, rhs, p)
    size = rhs.shape[0]
    systems = [np.moveaxis(v, 0, -1).reshape(-1) for v in (rhs, *bands.values())]
    length = systems[0].size
    ab = np.zeros((2 * p + 1, length))
    for d, flat in zip(bands, systems[1:], strict=True):  # ab[p - d, j + d] = A[j, j + d]
        ab[p - d, max(d, 0) : length + min(d, 0)] = flat[max(-d, 0) : length - max(d, 0)]
    x = solve_banded((p, p), ab, systems[0], check_finite=False)
    return np.moveaxis(x.reshape(*rhs.shape[1:], size), -1, 0)


def _eliminate(bands: dict[int, NDArray], rhs: NDArray, p: int) -> NDArray:
    """Banded Gaussian elimination without pivoting along the first axis, vectorised over
    the systems (the trailing axes), in place."""
    size = rhs.shape[0]
    a = {d: bands[d] if d in bands else np.zeros_like(rhs) for d in range(-p, p + 1)}
    x = rhs
    for i in range(size):  # rows of the systems, not pixels: each a vector over all systems
        for k in range(1, min(p, size - 1 - i) + 1):
            r = i + k
            factor = a[-k][r] / a[0][i]
            for j in range(1, p + 1):  # row r -= factor * row i, entry A[r, i + j]
                if j - k >= -p:
                    a[j - k][r] -= factor * a[j][i]
            x[r] -= factor * x[i]
    for i in range(size - 1, -1, -1):
        for j in range(1, min(p, size - 1 - i) + 1):
            x[i] -= a[j][i] * x[i + j]
        x[i] /= a[0][i]
    return x


def unmix_rows(
    sums: NDArray[np.float64],
    layout: CellLayout,
    geometry: StreakGeometry,
    floor: float = NEGLIGIBLE_COUPLING,
) -> NDArray[np.float64]:
    """Amplitudes (N, B') of stacked pixels from their cell sums (banded solve per column
    and bin); couplings below ``floor`` are neglected.

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
    # Stack position first, (S, G, B'): a row of all systems is one contiguous block.
    index = layout.index.T
    present = (index >= 0)[..., None]
    safe = np.where(index >= 0, index, 0)
    sigma = geometry.sigma
    y = geometry.y[safe]
    lo, hi = layout.lo[safe], layout.hi[safe]
    size = index.shape[0]
    # Own light in own cell, for every bin.
    bands = {0: np.where(present, ndtr((hi - y) / sigma) - ndtr((lo - y) / sigma), 1.0)}
    # Per bin, the closest spacing of stacked pixels and the cells' extents bound every
    # coupling, so the Gaussian integrals are evaluated only for bins where one matters.
    pairs = present[1:] & present[:-1]
    spacing = np.where(pairs, y[1:] - y[:-1], np.inf).min(axis=(0, 1), initial=np.inf)
    below = np.where(present, hi - y, -np.inf).max(axis=(0, 1))  # cell edge under its pixel
    above = np.where(present, y - lo, -np.inf).max(axis=(0, 1))  # ... and over it
    inner = np.minimum(np.where(present, hi - y, np.inf), np.where(present, y - lo, np.inf))
    inner = inner.min(axis=(0, 1))  # the nearest edge of any cell to its own pixel
    for distance in range(1, size):  # outwards from the diagonal while couplings matter
        found = False
        for d in (distance, -distance):
            # Pixel j + d's light beyond j's nearer cell edge bounds the coupling ...
            reach = below if d > 0 else above
            bins = np.flatnonzero(ndtr((reach - distance * spacing) / sigma) > floor)
            if bins.size == 0:
                continue
            k = np.arange(size) + d
            kk = np.clip(k, 0, size - 1)
            valid = present & present[kk] & ((k >= 0) & (k < size))[:, None, None]
            y_k = y[kk][..., bins]  # centre of pixel j + d, seen from pixel j's cell
            near_edge, far_edge = (hi, lo) if d > 0 else (lo, hi)
            sign = 1.0 if d > 0 else -1.0
            fraction = np.where(valid, ndtr(sign * (near_edge[..., bins] - y_k) / sigma[bins]), 0.0)
            strong = fraction.max(axis=(0, 1)) > floor  # the bound's bins, checked exactly
            if not strong.any():
                continue
            bins, y_k, fraction = bins[strong], y_k[..., strong], fraction[..., strong]
            # ... less its light beyond the farther edge, where that is not negligible.
            far = (-inner[bins] - distance * spacing[bins]) / sigma[bins]
            wide = np.flatnonzero(ndtr(far) > floor)
            if wide.size:
                edge = far_edge[..., bins[wide]]
                fraction[..., wide] -= ndtr(sign * (edge - y_k[..., wide]) / sigma[bins[wide]])
            bands[d] = np.zeros_like(y)
            bands[d][..., bins] = np.where(valid, fraction, 0.0)
            found = True
        if not found:
            break
    rhs = np.where(present, sums[safe], 0.0)
    amplitudes = _solve_banded(bands, rhs)  # one system per (SLM column, bin)
    out = np.empty_like(sums)
    out[index[index >= 0]] = amplitudes[index >= 0]
    return out
