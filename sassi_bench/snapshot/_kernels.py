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

Sample placement (:func:`place_samples`, one of the paper's per-frame steps) finds each
label's row runs in one pass (:func:`label_runs`) and searches a superpixel's own runs,
reading its pixels from a one-bit-per-pixel copy of ``blocked`` 64 at a time
(:func:`blocked_bits`); fills skip eight blocked bytes at a time (:func:`skip_bytes`). This
takes less CPU than a pixel-by-pixel search, with the same masks
(``docs/notes/2026-12-01-measured-in-code-comments.md``).

No on-disk cache: numba's cache pickles into the package folder (see
:mod:`sassi_bench.spectra._kernels`).
"""

from __future__ import annotations

import numba
import numpy as np

from sassi_bench.snapshot._slic import assign_row

_JIT = {"cache": False, "nogil": True}
#: Loops whose float sums may be reassociated (vectorised): the last bits change only.
_SUMS = dict(_JIT, fastmath={"reassoc", "contract"})


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


#: Eight bytes that are all 1 (or all 0), read as one word.
_ALL_ONES = np.uint64(0x0101010101010101)
_ALL_ZEROS = np.uint64(0)


@numba.njit(**_JIT)
def skip_bytes(flat, words, value, p, stop):  # pragma: no cover
    """The first index in ``p .. stop - 1`` where the 0/1 bytes ``flat`` differ from
    ``value``, else ``stop``. ``words`` is ``flat`` read as uint64: a word of eight bytes
    equal to ``value`` is skipped at once (the arrays scanned here are long stretches of one
    value: the blocked pixels of a mask, the label boundaries of a segmentation)."""
    pattern = _ALL_ONES if value else _ALL_ZEROS
    while p < stop:
        if p & 7 == 0 and p + 8 <= stop and words[p >> 3] == pattern:
            p += 8
            continue
        if flat[p] != value:
            return p
        p += 1
    return stop


@numba.njit(**_JIT)
def as_words(flat):  # pragma: no cover
    """The whole words of a flat uint8 array, as uint64 (a view)."""
    return flat[: (flat.size // 8) * 8].view(np.uint64)


@numba.njit(**_JIT)
def fill_raster(left, right, pitch, blocked, row_cols, row_count, mask):  # pragma: no cover
    """Open every pixel that keeps the rule, row by row, left to right.

    Once the samples are placed nearly every pixel is blocked (99.98 % at 698 x 931), so
    blocked pixels are skipped eight at a time (:func:`skip_bytes`; a pixel once blocked
    stays blocked, so skipping it is exact).
    """
    h, w = blocked.shape
    flat = blocked.reshape(h * w)
    words = as_words(flat)
    opened = 0
    p = skip_bytes(flat, words, 1, 0, h * w)
    while p < h * w:
        r = p // w
        c = p - r * w
        if is_free(r, c, left, right, pitch, blocked, row_cols, row_count):
            open_pixel(r, c, left, right, pitch, blocked, row_cols, row_count, mask)
            opened += 1
        p = skip_bytes(flat, words, 1, p + 1, h * w)
    return opened


#: ``(x & -x) * _BYTE_INDEX >> 56`` is the index of the lowest nonzero byte of ``x``.
_BYTE_INDEX = np.uint64(0x0001020304050607)


@numba.njit(**_JIT)
def run_starts(flat, w):  # pragma: no cover
    """Flat indices where a run of equal labels starts (every row starts one), ascending.

    The comparison of neighbours compiles to vector instructions; the flags are then read
    eight at a time and the set ones of a word found by bit arithmetic (the lowest set
    byte of ``x`` is ``(x & -x) * 0x0001020304050607 >> 56``), without a branch per pixel,
    which a byte loop or ``np.flatnonzero`` takes.
    """
    n = flat.size
    flags = np.empty(n, np.uint8)
    if n == 0:
        return np.empty(0, np.int64)
    flags[0] = 1
    for p in range(1, n):
        flags[p] = flat[p] != flat[p - 1]
    for p in range(0, n, w):
        flags[p] = 1
    words = as_words(flags)
    starts = np.empty(n, np.int64)
    m = 0
    one = np.uint64(1)
    for i in range(words.size):
        x = words[i]
        while x:
            low = x & (~x + one)
            starts[m] = 8 * i + ((low * _BYTE_INDEX) >> np.uint64(56))
            m += 1
            x ^= low
    for p in range(8 * words.size, n):
        if flags[p]:
            starts[m] = p
            m += 1
    return starts[:m]


@numba.njit(**_JIT)
def label_runs(labels, n_labels):  # pragma: no cover
    """Pixel count, centroid sums and runs of every label (negative labels skipped).

    Labels come in runs along a row (about a superpixel wide), so the runs are found first
    and each is added to its label's moments at once. The runs are then grouped by label
    (a counting sort that keeps raster order within a label): label ``k``'s runs are
    ``run_row``, ``run_start``, ``run_end`` (inclusive) at ``first[k] .. first[k + 1] - 1``,
    by row, then column. Returns ``count``, ``row_sum``, ``col_sum``, ``first``,
    ``run_row``, ``run_start``, ``run_end``.
    """
    h, w = labels.shape
    count = np.zeros(n_labels, np.int64)
    row_sum = np.zeros(n_labels, np.int64)  # exact, and integer adds are cheaper
    col_sum = np.zeros(n_labels, np.int64)
    runs_of = np.zeros(n_labels + 1, np.int64)
    n = h * w
    flat = labels.reshape(n)
    starts = run_starts(flat, w)
    raster_label = np.empty(starts.size, np.int32)
    raster_row = np.empty(starts.size, np.int32)
    raster_start = np.empty(starts.size, np.int32)
    raster_end = np.empty(starts.size, np.int32)
    n_runs = 0
    for i in range(starts.size):
        p = starts[i]
        k = flat[p]
        if k < 0:
            continue
        r = p // w
        c = p - r * w
        end = (starts[i + 1] if i + 1 < starts.size else n) - 1 - r * w
        run = end - c + 1
        count[k] += run
        row_sum[k] += r * run
        col_sum[k] += (c + end) * run // 2
        runs_of[k + 1] += 1
        raster_label[n_runs] = k
        raster_row[n_runs] = r
        raster_start[n_runs] = c
        raster_end[n_runs] = end
        n_runs += 1
    first = np.cumsum(runs_of)
    cursor = first[:-1].copy()
    run_row = np.empty(n_runs, np.int32)
    run_start = np.empty(n_runs, np.int32)
    run_end = np.empty(n_runs, np.int32)
    for i in range(n_runs):
        k = raster_label[i]
        j = cursor[k]
        cursor[k] += 1
        run_row[j] = raster_row[i]
        run_start[j] = raster_start[i]
        run_end[j] = raster_end[i]
    return count, row_sum, col_sum, first, run_row, run_start, run_end


def _bit_table():
    table = np.zeros(64, np.int64)
    for i in range(64):
        table[((1 << i) * _DE_BRUIJN) % (1 << 64) >> 58] = i
    return table


#: ``_BIT_INDEX[(b * _DE_BRUIJN) >> 58]`` is ``log2(b)`` for ``b`` a power of two (64 bits).
_DE_BRUIJN = 0x03F79D71B4CB0A89
_BIT_INDEX = _bit_table()
_ONES = np.uint64(0xFFFFFFFFFFFFFFFF)


@numba.njit(**_JIT)
def blocked_bits(blocked):  # pragma: no cover
    """``blocked`` as one bit per pixel, (H, ceil(W / 64)) uint64 (bit ``c % 64`` of word
    ``c // 64``): a search reads 64 pixels at once. Blocked words are found eight bytes at a
    time, so a fresh mask's empty map costs next to nothing."""
    h, w = blocked.shape
    bits = np.zeros((h, (w + 63) // 64), np.uint64)
    flat = blocked.reshape(h * w)
    words = as_words(flat)
    p = skip_bytes(flat, words, 0, 0, h * w)
    while p < h * w:
        r = p // w
        c = p - r * w
        bits[r, c >> 6] |= np.uint64(1) << np.uint64(c & 63)
        p = skip_bytes(flat, words, 0, p + 1, h * w)
    return bits


@numba.njit(**_JIT)
def span_bits(word, c0, c1):  # pragma: no cover
    """The bits of columns ``c0 .. c1`` (inclusive) that fall in word ``word``."""
    lo = max(c0 - 64 * word, 0)
    hi = min(c1 - 64 * word, 63)
    return (_ONES >> np.uint64(63 - hi)) & (_ONES << np.uint64(lo))


@numba.njit(**_JIT)
def paint_bits(bits, r0, r1, c0, c1):  # pragma: no cover
    """Set the bits of rows ``r0 .. r1 - 1``, columns ``c0 .. c1`` (inclusive)."""
    for word in range(c0 >> 6, (c1 >> 6) + 1):
        span = span_bits(word, c0, c1)
        for r in range(r0, r1):
            bits[r, word] |= span


@numba.njit(**_JIT)
def nearest_free_in_runs(
    lo,
    hi,
    run_row,
    run_start,
    run_end,
    cr,
    cc,
    r0,
    left,
    right,
    pitch,
    bits,
    row_cols,
    row_count,
    band,
):  # pragma: no cover
    """The free pixel of runs ``lo .. hi - 1`` (one label's, by row then column) nearest to
    ``(cr, cc)``, as ``(row, column)``, or ``(-1, -1)`` when none is free.

    Rows are visited by their distance to row ``r0``: ``r0, r0 + 1, r0 - 1, r0 + 2, ...``,
    and each row's pixels left to right; a pixel replaces the best only when strictly
    nearer. Each direction stops at the first row farther from ``cr`` than the best pixel.
    Unblocked pixels are read from ``bits`` (:func:`blocked_bits`) 64 at a time; each is
    checked against the open columns of the rows its window spans, gathered into ``band``
    once per row (a row's candidates share them).
    """
    h = bits.shape[0]
    best = np.inf
    best_r = -1
    best_c = -1
    # down: the first run at row >= r0 (binary search); up: the run before it.
    a = lo
    b = hi
    while a < b:
        m = (a + b) // 2
        if run_row[m] < r0:
            a = m + 1
        else:
            b = m
    down = a
    up = a - 1
    while down < hi or up >= lo:
        go_down = down < hi and (up < lo or run_row[down] - r0 <= r0 - run_row[up])
        if go_down:
            rr = run_row[down]
            g0 = down
            while down < hi and run_row[down] == rr:
                down += 1
            g1 = down
        else:
            rr = run_row[up]
            g1 = up + 1
            while up >= lo and run_row[up] == rr:
                up -= 1
            g0 = up + 1
        dr2 = (rr - cr) * (rr - cr)
        if dr2 >= best:
            # Rows beyond this one in the same direction are farther still.
            if go_down:
                down = hi
            else:
                up = lo - 1
            continue
        n_band = -1  # the open columns near row rr, gathered at its first unblocked pixel
        for j in range(g0, g1):
            c0 = run_start[j]
            c1 = run_end[j]
            nearest = min(max(cc, c0), c1)
            if dr2 + (nearest - cc) * (nearest - cc) >= best:
                continue
            for word in range(c0 >> 6, (c1 >> 6) + 1):
                free = ~bits[rr, word] & span_bits(word, c0, c1)
                while free:
                    low = free & (~free + np.uint64(1))
                    free ^= low
                    c = 64 * word + _BIT_INDEX[(low * np.uint64(_DE_BRUIJN)) >> np.uint64(58)]
                    dist = dr2 + (c - cc) * (c - cc)
                    if dist >= best:
                        continue
                    if n_band < 0:
                        n_band = 0
                        for ro in range(max(0, rr - pitch + 1), min(h, rr + pitch)):
                            for i in range(row_count[ro]):
                                band[n_band] = row_cols[ro, i]
                                n_band += 1
                    lo_c = c - left[rr, c]
                    hi_c = c + right[rr, c]
                    is_free_here = True
                    for i in range(n_band):
                        if lo_c <= band[i] <= hi_c:
                            is_free_here = False
                            break
                    if is_free_here:
                        best = dist
                        best_r = rr
                        best_c = c
    return best_r, best_c


@numba.njit(**_JIT)
def place_samples(
    labels, n_labels, left, right, pitch, blocked, row_cols, row_count, mask, samples, owner
):  # pragma: no cover
    """The paper's first two steps: every superpixel's centroid as a sample, moved to the
    nearest free pixel of its superpixel when the spacing forbids it, else dropped.

    Superpixels are visited in label order. The rounded centroid is taken when it is in the
    superpixel and free; else the nearest free pixel (Euclidean, from the centroid) is
    searched among the superpixel's own row runs (:func:`nearest_free_in_runs`): most
    centroids are forbidden when superpixels are smaller than the spacing, and the runs
    visit only the superpixel's pixels, not its bounding box. Writes ``samples`` (n, 2:
    row, col) and ``owner`` (superpixel -> sample index or -1); returns the number of
    samples.
    """
    count, row_sum, col_sum, first, run_row, run_start, run_end = label_runs(labels, n_labels)
    band = np.empty((2 * pitch - 1) * row_cols.shape[1], np.int32)
    bits = blocked_bits(blocked)
    h, w = blocked.shape
    n = 0
    for k in range(n_labels):
        owner[k] = -1
        lo = first[k]
        hi = first[k + 1]
        if count[k] == 0:
            continue
        cr = row_sum[k] / count[k]
        cc = col_sum[k] / count[k]
        r0 = min(max(int(np.floor(cr + 0.5)), run_row[lo]), run_row[hi - 1])
        c0 = int(np.floor(cc + 0.5))
        # Most centroids that fit are taken without a search.
        if (
            0 <= c0 < w
            and labels[r0, c0] == k
            and is_free(r0, c0, left, right, pitch, blocked, row_cols, row_count)
        ):
            best_r = r0
            best_c = c0
        else:
            best_r, best_c = nearest_free_in_runs(
                lo, hi, run_row, run_start, run_end, cr, cc, r0,
                left, right, pitch, bits, row_cols, row_count, band,
            )  # fmt: skip
        if best_r >= 0:
            open_pixel(best_r, best_c, left, right, pitch, blocked, row_cols, row_count, mask)
            paint_bits(
                bits,
                max(0, best_r - pitch + 1),
                min(h, best_r + pitch),
                max(0, best_c - left[best_r, best_c]),
                min(w - 1, best_c + right[best_r, best_c]),
            )
            samples[n, 0] = best_r
            samples[n, 1] = best_c
            owner[k] = n
            n += 1
    return n


@numba.njit(**_JIT)
def planes(features):  # pragma: no cover
    """(H, W, C) features as (C, H, W) float32 planes: a row of one channel is contiguous,
    so the assignment's distance loops run on vectors."""
    h, w, nc = features.shape
    out = np.empty((nc, h, w), np.float32)
    for r in range(h):
        for c in range(w):
            for ch in range(nc):
                out[ch, r, c] = features[r, c, ch]
    return out


@numba.njit(**_SUMS)
def assign_to_samples(
    planes, samples, radius, spatial_weight, labels, distance
):  # pragma: no cover
    """One SLIC assignment pass with fixed centres: every pixel within ``radius`` (Chebyshev)
    of a sample takes the sample with the smallest ``|f - f_s|^2 + spatial_weight * |p - p_s|^2``,
    where ``f_s`` is the mean feature of the 3 x 3 pixels around the sample (features as
    (C, H, W) :func:`planes`). Pixels no sample reaches keep label -1; ties go to the
    first sample.

    Each window row is done as whole vectors (float32): the squared distances of its
    pixels, channel by channel, then one compare-and-select pass, with no branch per
    pixel: cheaper than testing the spatial distance of every pixel first, with the same
    labels (``docs/notes/2026-12-01-measured-in-code-comments.md``)."""
    nc, h, w = planes.shape
    centre = np.zeros(nc, np.float32)
    dc = np.empty(2 * radius + 1, np.float32)
    d = np.empty(2 * radius + 1, np.float32)
    for n in range(samples.shape[0]):
        r = samples[n, 0]
        c = samples[n, 1]
        m = 0
        for ch in range(nc):
            total = 0.0
            m = 0
            for rr in range(max(0, r - 1), min(h, r + 2)):
                for cc in range(max(0, c - 1), min(w, c + 2)):
                    total += planes[ch, rr, cc]
                    m += 1
            centre[ch] = total / m
        c0 = max(0, c - radius)
        c1 = min(w, c + radius + 1)
        span = c1 - c0
        for q in range(span):
            dc[q] = (c0 + q - c) * (c0 + q - c) * spatial_weight
        label = np.int32(n)
        for rr in range(max(0, r - radius), min(h, r + radius + 1)):
            dr = np.float32((rr - r) * (rr - r) * spatial_weight)
            assign_row(planes, rr, c0, c1, dr, dc, centre, label, d, distance, labels)


@numba.njit(**_JIT)
def spread_regions(ratio, regions, scale, out):  # pragma: no cover
    """``out[r, c, :] = ratio[regions[r, c], :] * scale[r, c]``: the cube written once (the
    numpy gather then product passes over the (H, W, B) cube three times)."""
    h, w = regions.shape
    bands = ratio.shape[1]
    for r in range(h):
        for c in range(w):
            k = regions[r, c]
            s = scale[r, c]
            for b in range(bands):
                out[r, c, b] = ratio[k, b] * s


@numba.njit(**_JIT)
def weighted_lines(sum_p, sum_pi, safe, n, mean_i, denominator, present, a, b):  # pragma: no cover
    """Per window, the guided filter's line ``a I + b`` times the window's measured share
    ``n`` (zero where no pixel is measured): with ``mean_p = sum_p / safe`` and
    ``mean_pi = sum_pi / safe`` (the box means of the measured values, and of their
    products with the guide), ``a = (mean_pi - mean_i mean_p) / denominator``,
    ``b = mean_p - a mean_i``. Arrays (H, W[, K]) float32; one pass instead of a dozen
    numpy temporaries."""
    h, w, k = sum_p.shape
    for r in range(h):
        for c in range(w):
            if not present[r, c]:
                for j in range(k):
                    a[r, c, j] = 0.0
                    b[r, c, j] = 0.0
                continue
            # Two divisions a pixel, not two a band (they were most of the time).
            inv_share = np.float32(1.0) / safe[r, c]
            inv_den = np.float32(1.0) / denominator[r, c]
            weight, centre = n[r, c], mean_i[r, c]
            for j in range(k):
                mean_p = sum_p[r, c, j] * inv_share
                slope = (sum_pi[r, c, j] * inv_share - centre * mean_p) * inv_den
                a[r, c, j] = weight * slope
                b[r, c, j] = weight * (mean_p - slope * centre)


@numba.njit(**_JIT)
def apply_lines(sum_a, sum_b, guide, norm, out, start):  # pragma: no cover
    """``out[..., start + j] = (sum_a[..., j] guide + sum_b[..., j]) / norm``."""
    h, w, k = sum_a.shape
    for r in range(h):
        for c in range(w):
            inv = np.float32(1.0) / norm[r, c]
            g = guide[r, c]
            for j in range(k):
                out[r, c, start + j] = (sum_a[r, c, j] * g + sum_b[r, c, j]) * inv
