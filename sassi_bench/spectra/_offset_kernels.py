"""Compiled loops of the offset removal (numba, compiled on first use; no on-disk cache, see
:mod:`sassi_bench.spectra._kernels`).

The block medians of a frame's free pixels are one pass that gathers each block's free
pixels into a small buffer and takes their median, with no NaN-padded float64 copy of the
frame, no transposed tile array and no ``np.nanmedian`` over it; the blocks without enough
free pixels are filled from the known blocks along their row and column in one pass each,
not by a Delaunay triangulation of the block grid (``griddata``), which takes far longer
(``docs/notes/2026-12-01-measured-in-code-comments.md``).
"""

from __future__ import annotations

import numpy as np
from numba import njit

_JIT = {"cache": False, "nogil": True}

#: An end value carried beyond the last known block counts as bridging this many times
#: its distance: beside an interpolation across the other axis it weighs next to nothing.
_EXTRAPOLATED = 1000.0


@njit(**_JIT)
def block_medians(frame, footprint, by, bx, min_free, medians, free):  # pragma: no cover
    """Median of the pixels outside ``footprint`` in every ``by`` x ``bx`` block of
    ``frame`` (blocks at the right and bottom edges may be smaller), written to
    ``medians`` (ny, nx) float64, NaN where the free share ``free`` (ny, nx) of a block's
    ``by * bx`` pixels is below ``min_free``."""
    h, w = frame.shape
    ny, nx = medians.shape
    buffer = np.empty(by * bx, np.float64)
    for i in range(ny):
        r0 = i * by
        r1 = min(h, r0 + by)
        for j in range(nx):
            c0 = j * bx
            c1 = min(w, c0 + bx)
            n = 0
            for r in range(r0, r1):
                for c in range(c0, c1):
                    if not footprint[r, c]:
                        buffer[n] = frame[r, c]
                        n += 1
            free[i, j] = n / (by * bx)
            if n > 0 and free[i, j] >= min_free:
                medians[i, j] = np.median(buffer[:n])
            else:
                medians[i, j] = np.nan


@njit(**_JIT)
def fill_along_rows(values, step):  # pragma: no cover
    """Every NaN of ``values`` (ny, nx) filled along its row: linearly between the nearest
    known values of the row, with the end value beyond them. Returns the filled copy and,
    per entry, the length (in units of ``step``) the value was bridged over: 0 where known,
    the gap between the two known values around it, ``_EXTRAPOLATED`` times the distance
    to the one known value beyond the ends, and inf in rows with no known value."""
    ny, nx = values.shape
    filled = values.copy()
    gap = np.zeros((ny, nx), np.float64)
    for i in range(ny):
        last = -1
        for j in range(nx):
            if np.isnan(values[i, j]):
                continue
            if last < 0:
                for k in range(j):
                    filled[i, k] = values[i, j]
                    gap[i, k] = _EXTRAPOLATED * (j - k) * step
            else:
                for k in range(last + 1, j):
                    t = (k - last) / (j - last)
                    filled[i, k] = (1.0 - t) * values[i, last] + t * values[i, j]
                    gap[i, k] = (j - last) * step
            last = j
        if last < 0:
            for k in range(nx):
                gap[i, k] = np.inf
        else:
            for k in range(last + 1, nx):
                filled[i, k] = values[i, last]
                gap[i, k] = _EXTRAPOLATED * (k - last) * step
    return filled, gap


@njit(**_JIT)
def fill_holes(values, by, bx):  # pragma: no cover
    """Fill the NaN of a block grid (ny, nx) in place from the known blocks around them:
    the interpolations along the block row and along the block column (:func:`fill_along_rows`),
    each weighted by the inverse square of the length it bridges in pixels (``by``, ``bx``
    the block's rows and columns), so the nearer known blocks decide. Linear between known
    blocks, as a 2-D linear interpolation would be, in one pass each way."""
    ny, nx = values.shape
    along_rows, gap_rows = fill_along_rows(values, float(bx))
    along_cols, gap_cols = fill_along_rows(np.ascontiguousarray(values.T), float(by))
    for i in range(ny):
        for j in range(nx):
            if not np.isnan(values[i, j]):
                continue
            g_r = gap_rows[i, j]
            g_c = gap_cols[j, i]
            if np.isfinite(g_r) and np.isfinite(g_c):
                w_r = 1.0 / (g_r * g_r)
                w_c = 1.0 / (g_c * g_c)
                values[i, j] = (w_r * along_rows[i, j] + w_c * along_cols[j, i]) / (w_r + w_c)
            elif np.isfinite(g_r):
                values[i, j] = along_rows[i, j]
            elif np.isfinite(g_c):
                values[i, j] = along_cols[j, i]


@njit(**_JIT)
def squared_residual(frame, footprint, image):  # pragma: no cover
    """Sum of ``(frame - image) ** 2`` over the pixels outside ``footprint``, and their
    count."""
    h, w = frame.shape
    total = 0.0
    n = 0
    for r in range(h):
        for c in range(w):
            if not footprint[r, c]:
                d = frame[r, c] - image[r, c]
                total += d * d
                n += 1
    return total, n
