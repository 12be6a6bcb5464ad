"""Compiled loops of mask design and re-segmentation (numba, compiled on first use).

Opening pixels one after another under the spacing rule is sequential by nature (each
opened pixel changes what the next may do), so it is a compiled loop, not numpy. The state
of a mask being built:

* ``blocked`` ``(H, W)`` uint8: 1 inside the forbidden window of an open pixel, so a
  candidate inside one is refused in O(1);
* ``row_cols`` ``(H, cap)`` int32 and ``row_count`` ``(H,)``: the open columns of every
  row, so a candidate's own window (which may reach pixels whose windows do not reach it:
  the windows change over the field) is checked against the few open pixels of the rows
  it spans, not pixel by pixel;
* ``mask`` ``(H, W)`` bool.

No on-disk cache: numba's cache pickles into the package folder (see
:mod:`sassi_bench.spectra._kernels`).
"""

from __future__ import annotations

import numba
import numpy as np

_JIT = {"cache": False, "nogil": True}


@numba.njit(**_JIT)
def is_free(r, c, left, right, pitch, blocked, row_cols, row_count):  # pragma: no cover
    """True if opening ``(c, r)`` keeps the rule with every pixel open so far."""
    if blocked[r, c]:
        return False
    h = blocked.shape[0]
    lo = c - left[r, c]
    hi = c + right[r, c]
    for rr in range(max(0, r - pitch + 1), min(h, r + pitch)):
        for k in range(row_count[rr]):
            cc = row_cols[rr, k]
            if lo <= cc <= hi:
                return False
    return True


@numba.njit(**_JIT)
def open_pixel(r, c, left, right, pitch, blocked, row_cols, row_count, mask):  # pragma: no cover
    """Open ``(c, r)``: paint its forbidden window into ``blocked`` and record it."""
    h, w = blocked.shape
    c0 = max(0, c - left[r, c])
    c1 = min(w - 1, c + right[r, c])
    for rr in range(max(0, r - pitch + 1), min(h, r + pitch)):
        blocked[rr, c0 : c1 + 1] = 1
    row_cols[r, row_count[r]] = c
    row_count[r] += 1
    mask[r, c] = True


@numba.njit(**_JIT)
def fill_in_order(
    order, limit, left, right, pitch, blocked, row_cols, row_count, mask
):  # pragma: no cover
    """Open the pixels of ``order`` (flat indices) that keep the rule, at most ``limit``."""
    w = blocked.shape[1]
    opened = 0
    for i in range(order.size):
        if opened >= limit:
            break
        r = order[i] // w
        c = order[i] - r * w
        if is_free(r, c, left, right, pitch, blocked, row_cols, row_count):
            open_pixel(r, c, left, right, pitch, blocked, row_cols, row_count, mask)
            opened += 1
    return opened


@numba.njit(**_JIT)
def fill_raster(left, right, pitch, blocked, row_cols, row_count, mask):  # pragma: no cover
    """Open every pixel that keeps the rule, row by row, left to right."""
    h, w = blocked.shape
    opened = 0
    for r in range(h):
        for c in range(w):
            if blocked[r, c] == 0 and is_free(
                r, c, left, right, pitch, blocked, row_cols, row_count
            ):
                open_pixel(r, c, left, right, pitch, blocked, row_cols, row_count, mask)
                opened += 1
    return opened


@numba.njit(**_JIT)
def label_moments(labels, n_labels):  # pragma: no cover
    """Pixel count, centroid sums and bounding box of every label (negative labels skipped).

    Returns ``count``, ``row_sum``, ``col_sum`` and ``box`` (n, 4: row0, row1, col0, col1).
    """
    h, w = labels.shape
    count = np.zeros(n_labels, np.int64)
    row_sum = np.zeros(n_labels, np.float64)
    col_sum = np.zeros(n_labels, np.float64)
    box = np.empty((n_labels, 4), np.int64)
    box[:, 0] = h
    box[:, 1] = -1
    box[:, 2] = w
    box[:, 3] = -1
    for r in range(h):
        for c in range(w):
            k = labels[r, c]
            if k < 0:
                continue
            count[k] += 1
            row_sum[k] += r
            col_sum[k] += c
            box[k, 0] = min(box[k, 0], r)
            box[k, 1] = max(box[k, 1], r)
            box[k, 2] = min(box[k, 2], c)
            box[k, 3] = max(box[k, 3], c)
    return count, row_sum, col_sum, box


@numba.njit(**_JIT)
def place_samples(
    labels, n_labels, left, right, pitch, blocked, row_cols, row_count, mask, samples, owner
):  # pragma: no cover
    """The paper's first two steps: every superpixel's centroid as a sample, moved to the
    nearest free pixel of its superpixel when the spacing forbids it, else dropped.

    Superpixels are visited in label order. "Nearest" is the smallest Chebyshev ring
    around the centroid holding a free pixel of the superpixel, and within it the
    Euclidean nearest. Writes ``samples`` (n, 2: row, col) and ``owner`` (superpixel ->
    sample index or -1); returns the number of samples.
    """
    h, w = labels.shape
    count, row_sum, col_sum, box = label_moments(labels, n_labels)
    n = 0
    for k in range(n_labels):
        owner[k] = -1
        if count[k] == 0:
            continue
        cr = row_sum[k] / count[k]
        cc = col_sum[k] / count[k]
        r0 = min(max(int(np.floor(cr + 0.5)), 0), h - 1)
        c0 = min(max(int(np.floor(cc + 0.5)), 0), w - 1)
        reach = max(max(r0 - box[k, 0], box[k, 1] - r0), max(c0 - box[k, 2], box[k, 3] - c0))
        best_r = -1
        best_c = -1
        for d in range(reach + 1):
            best = np.inf
            for rr in range(max(r0 - d, box[k, 0]), min(r0 + d, box[k, 1]) + 1):
                edge = rr == r0 - d or rr == r0 + d
                first = max(c0 - d, box[k, 2]) if edge else c0 - d
                last = min(c0 + d, box[k, 3]) if edge else c0 + d
                step = 1 if edge else 2 * d
                for ccol in range(first, last + 1, step):
                    if ccol < box[k, 2] or ccol > box[k, 3] or labels[rr, ccol] != k:
                        continue
                    if is_free(rr, ccol, left, right, pitch, blocked, row_cols, row_count):
                        dist = (rr - cr) ** 2 + (ccol - cc) ** 2
                        if dist < best:
                            best = dist
                            best_r = rr
                            best_c = ccol
            if best_r >= 0:
                break
        if best_r >= 0:
            open_pixel(best_r, best_c, left, right, pitch, blocked, row_cols, row_count, mask)
            samples[n, 0] = best_r
            samples[n, 1] = best_c
            owner[k] = n
            n += 1
    return n


@numba.njit(**_JIT)
def assign_to_samples(
    features, samples, radius, spatial_weight, labels, distance
):  # pragma: no cover
    """One SLIC assignment pass with fixed centres: every pixel within ``radius`` (Chebyshev)
    of a sample takes the sample with the smallest ``|f - f_s|^2 + spatial_weight * |p - p_s|^2``,
    where ``f_s`` is the mean feature of the 3 x 3 pixels around the sample. Pixels no sample
    reaches keep label -1."""
    h, w, nc = features.shape
    centre = np.zeros(nc, np.float64)
    for n in range(samples.shape[0]):
        r = samples[n, 0]
        c = samples[n, 1]
        centre[:] = 0.0
        m = 0
        for rr in range(max(0, r - 1), min(h, r + 2)):
            for cc in range(max(0, c - 1), min(w, c + 2)):
                for ch in range(nc):
                    centre[ch] += features[rr, cc, ch]
                m += 1
        centre /= m
        for rr in range(max(0, r - radius), min(h, r + radius + 1)):
            dr2 = (rr - r) * (rr - r) * spatial_weight
            for cc in range(max(0, c - radius), min(w, c + radius + 1)):
                d = dr2 + (cc - c) * (cc - c) * spatial_weight
                if d >= distance[rr, cc]:
                    continue
                for ch in range(nc):
                    diff = features[rr, cc, ch] - centre[ch]
                    d += diff * diff
                if d < distance[rr, cc]:
                    distance[rr, cc] = d
                    labels[rr, cc] = n
