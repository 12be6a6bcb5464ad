"""Compiled SLIC (numba, compiled on first use; no on-disk cache, see
:mod:`sassi_bench.spectra._kernels`): Achanta et al.'s simple linear iterative clustering
on feature planes, with the connectivity clean-up, for video superpixels.

Why our own: OpenCV's ximgproc SLIC works on interleaved features and tests every pixel
of a window with branches; here a window row is one vectorised pass (as the
re-segmentation's :func:`~sassi_bench.snapshot._kernels.assign_to_samples`), and a video
can start the clustering from the previous frame's centres instead of a fresh grid (see
:mod:`sassi_bench.snapshot.superpixels` for the measurements).
"""

from __future__ import annotations

import numba
import numpy as np

_JIT = {"cache": False, "nogil": True}
_SUMS = dict(_JIT, fastmath={"reassoc", "contract"})


@numba.njit(inline="always", **_JIT)
def assign_row(planes, rr, c0, c1, dr, dc, centre, label, d, distance, labels):  # pragma: no cover
    """One row of a centre's window in a SLIC assignment: every pixel of row ``rr``,
    columns ``c0:c1``, takes ``label`` where ``dr + dc + |f - centre|^2`` is below its best
    distance so far (``d`` is scratch). Whole float32 vectors, no branch per pixel."""
    n = c1 - c0
    for q in range(n):
        d[q] = dr + dc[q]
    for ch in range(planes.shape[0]):
        row = planes[ch, rr, c0:c1]
        f = centre[ch]
        for q in range(n):
            e = row[q] - f
            d[q] += e * e
    best = distance[rr, c0:c1]
    owner = labels[rr, c0:c1]
    for q in range(n):
        nearer = d[q] < best[q]
        best[q] = d[q] if nearer else best[q]
        owner[q] = label if nearer else owner[q]


@numba.njit(**_JIT)
def scaled_by_peak(image):  # pragma: no cover
    """``image / max(image)`` (float32; unscaled when the peak is not positive) and whether
    every value is finite."""
    flat = image.reshape(image.size)
    peak = np.float32(-np.inf)
    finite = True
    for i in range(flat.size):
        v = flat[i]
        finite &= np.isfinite(v)
        peak = max(peak, v)
    out = np.empty_like(image)
    target = out.reshape(out.size)
    if peak > 0:
        for i in range(flat.size):
            target[i] = flat[i] / peak
    else:
        target[:] = flat
    return out, finite


@numba.njit(**_JIT)
def halve(planes):  # pragma: no cover
    """(C, H, W) planes shrunk by 2 (the mean of every 2 x 2 block; an odd last row or
    column is dropped, as OpenCV's area resize to ``W // 2`` x ``H // 2`` does)."""
    nc, h, w = planes.shape
    h2, w2 = h // 2, w // 2
    out = np.empty((nc, h2, w2), np.float32)
    for ch in range(nc):
        for r in range(h2):
            top = planes[ch, 2 * r]
            bottom = planes[ch, 2 * r + 1]
            row = out[ch, r]
            for c in range(w2):
                row[c] = np.float32(0.25) * (
                    (top[2 * c] + top[2 * c + 1]) + (bottom[2 * c] + bottom[2 * c + 1])
                )
    return out


@numba.njit(**_JIT)
def enlarge(labels, h, w):  # pragma: no cover
    """Labels of a grid shrunk by 2 back on the (h, w) grid (nearest: the last small row
    and column also cover an odd last row and column)."""
    h2, w2 = labels.shape
    out = np.empty((h, w), labels.dtype)
    for r in range(h):
        source = labels[min(r // 2, h2 - 1)]
        row = out[r]
        for c in range(w):
            row[c] = source[min(c // 2, w2 - 1)]
    return out


@numba.njit(**_JIT)
def grid_centres(planes, step):  # pragma: no cover
    """SLIC's first centres: a grid of ``step`` px, each moved to the lowest colour
    gradient of its 3 x 3 neighbourhood (off edges), as (K, 2) float32 (row, column)."""
    nc, h, w = planes.shape
    ny = max(1, int(h / step + 0.5))
    nx = max(1, int(w / step + 0.5))
    sy, sx = h / ny, w / nx
    out = np.empty((ny * nx, 2), np.float32)
    k = 0
    for i in range(ny):
        for j in range(nx):
            r0 = min(h - 1, int((i + 0.5) * sy))
            c0 = min(w - 1, int((j + 0.5) * sx))
            best_r, best_c, best = r0, c0, np.inf
            for r in range(max(1, r0 - 1), min(h - 1, r0 + 2)):
                for c in range(max(1, c0 - 1), min(w - 1, c0 + 2)):
                    g = 0.0
                    for ch in range(nc):
                        dx = planes[ch, r, c + 1] - planes[ch, r, c - 1]
                        dy = planes[ch, r + 1, c] - planes[ch, r - 1, c]
                        g += dx * dx + dy * dy
                    if g < best:
                        best_r, best_c, best = r, c, g
            out[k, 0] = best_r
            out[k, 1] = best_c
            k += 1
    return out


@numba.njit(**_JIT)
def carry_centres(previous, grid, h, w, step):  # pragma: no cover
    """Centres for a new frame of a video: each cell of :func:`grid_centres`' grid takes
    the previous frame's centre in it nearest to its grid point, or its grid point when
    none is left in it (the scene moved on); so the centres follow the scene without
    crowding where it moved to or leaving a gap where it came from."""
    ny = max(1, int(h / step + 0.5))
    nx = max(1, int(w / step + 0.5))
    sy, sx = h / ny, w / nx
    out = grid.copy()
    best = np.full(ny * nx, np.inf)
    for k in range(previous.shape[0]):
        r, c = previous[k, 0], previous[k, 1]
        i = int(r / sy)
        j = int(c / sx)
        if not (0 <= i < ny and 0 <= j < nx):
            continue
        cell = i * nx + j
        d = (r - (i + 0.5) * sy) ** 2 + (c - (j + 0.5) * sx) ** 2
        if d < best[cell]:
            best[cell] = d
            out[cell, 0] = r
            out[cell, 1] = c
    return out


@numba.njit(**_SUMS)
def cluster(planes, positions, step, compactness, iterations, labels):  # pragma: no cover
    """SLIC from the centres at ``positions`` (K, 2) (row, column; updated in place):
    ``iterations`` rounds of assigning every pixel within ``step`` (Chebyshev) of a centre
    to the centre of smallest ``|f - f_k|^2 + (compactness / step)^2 |p - p_k|^2`` (ties
    to the first), then moving every centre to the mean position and features of its
    pixels. The centres' features start as the features at their positions. Pixels no
    centre reaches take -1. Writes ``labels`` (H, W) int32; returns the centres' pixel
    counts."""
    nc, h, w = planes.shape
    k_count = positions.shape[0]
    weight = np.float32((compactness / step) ** 2)
    colours = np.empty((k_count, nc), np.float32)
    for k in range(k_count):
        r = min(h - 1, max(0, int(positions[k, 0] + 0.5)))
        c = min(w - 1, max(0, int(positions[k, 1] + 0.5)))
        for ch in range(nc):
            colours[k, ch] = planes[ch, r, c]
    distance = np.empty((h, w), np.float32)
    span = 2 * step + 1
    dc = np.empty(span, np.float32)
    d = np.empty(span, np.float32)
    counts = np.zeros(k_count, np.int64)
    sums = np.zeros((k_count, 2 + nc))
    for _ in range(iterations):
        distance[:] = np.inf
        labels[:] = -1
        for k in range(k_count):
            r = int(positions[k, 0] + 0.5)
            c = int(positions[k, 1] + 0.5)
            c0 = max(0, c - step)
            c1 = min(w, c + step + 1)
            n = c1 - c0
            if n <= 0:
                continue
            for q in range(n):
                x = np.float32(c0 + q) - positions[k, 1]
                dc[q] = x * x * weight
            label = np.int32(k)
            for rr in range(max(0, r - step), min(h, r + step + 1)):
                y = np.float32(rr) - positions[k, 0]
                dr = y * y * weight
                assign_row(planes, rr, c0, c1, dr, dc, colours[k], label, d, distance, labels)
        counts[:] = 0
        sums[:] = 0.0
        for r in range(h):
            for c in range(w):
                k = labels[r, c]
                if k < 0:
                    continue
                counts[k] += 1
                sums[k, 0] += r
                sums[k, 1] += c
                for ch in range(nc):
                    sums[k, 2 + ch] += planes[ch, r, c]
        for k in range(k_count):
            if counts[k] == 0:
                continue  # an empty cluster keeps its centre
            positions[k, 0] = sums[k, 0] / counts[k]
            positions[k, 1] = sums[k, 1] / counts[k]
            for ch in range(nc):
                colours[k, ch] = sums[k, 2 + ch] / counts[k]
    return counts


@numba.njit(**_JIT)
def connect(labels, min_size):  # pragma: no cover
    """SLIC's connectivity clean-up: every 4-connected component of a label becomes a
    label of its own, numbered in raster order; a component under ``min_size`` pixels (or
    of pixels no centre reached, label -1) joins the component it touches first (the
    one above or to the left of its first pixel, else the first one it borders).
    Returns the new labels (H, W) int32 and their number."""
    h, w = labels.shape
    out = np.full((h, w), -1, np.int32)
    stack = np.empty(h * w, np.int64)
    count = 0
    for start in range(h * w):
        r0 = start // w
        c0 = start - r0 * w
        if out[r0, c0] >= 0:
            continue
        original = labels[r0, c0]
        # A neighbour labelled already: above or left of the component's first pixel.
        adjacent = -1
        if c0 > 0:
            adjacent = out[r0, c0 - 1]
        elif r0 > 0:
            adjacent = out[r0 - 1, c0]
        out[r0, c0] = count
        stack[0] = start
        top = 1
        size = 0
        while top > 0:
            top -= 1
            p = stack[top]
            size += 1
            r = p // w
            c = p - r * w
            for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                rr = r + dr
                cc = c + dc
                if rr < 0 or rr >= h or cc < 0 or cc >= w:
                    continue
                if out[rr, cc] < 0 and labels[rr, cc] == original:
                    out[rr, cc] = count
                    stack[top] = rr * w + cc
                    top += 1
                elif adjacent < 0 and out[rr, cc] >= 0 and out[rr, cc] != count:
                    adjacent = out[rr, cc]
        if (size < min_size or original < 0) and adjacent >= 0:
            # Relabel the component (found again by its new label) to its neighbour.
            stack[0] = start
            top = 1
            out[r0, c0] = adjacent
            while top > 0:
                top -= 1
                p = stack[top]
                r = p // w
                c = p - r * w
                for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1)):
                    rr = r + dr
                    cc = c + dc
                    if 0 <= rr < h and 0 <= cc < w and out[rr, cc] == count:
                        out[rr, cc] = adjacent
                        stack[top] = rr * w + cc
                        top += 1
        else:
            count += 1
    return out, count
