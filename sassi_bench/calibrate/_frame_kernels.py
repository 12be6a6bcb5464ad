"""Compiled per-pixel loops over camera frames (numba): the sweep decoders (one pass
per frame, one per axis), running sums of frames, and the lamp frames' moments.

Why compiled: a prototype frame is 4.2 million pixels. The Gray and phase decoders did
a handful of whole-frame numpy passes per frame (dark subtraction, contrast, running
minima, the saturation test), each a temporary of 16 MB, and then held an axis's frames
as float32 stacks; fused, each frame is read once, pixel by pixel, with no temporary
(a tenth of the CPU: ``docs/notes/2026-12-01-measured-in-code-comments.md``). The outlier
screen needs, per valid pixel, whether the median of its 5 x 5
window lies within ``max_jump`` of it: where more than half the window lies within
half that distance, the median does too and no sort is needed (nearly every pixel of a
smooth map); only the others are sorted (:func:`window_outliers`).

The grey response's trimmed mean (:func:`trimmed_ratio_mean`) replaces scipy's
``trim_mean`` on each level's normalised lit pixels: scipy partitions all of them (2.1
million float64 ratios on a prototype frame, made by four whole-array numpy passes)
where one fused pass counts and sums, and only the few per cent of ratios near the two
cuts, bracketed by a strided sample, are partitioned (the same values trimmed, summed
in another order: equal to rounding; timed in
``docs/notes/2026-11-29-docstring-measurements.md``).

Every function works on plain arrays, releases the GIL, and (but for the trimmed mean's
summation order) gives the same numbers as the numpy expressions it replaces (the same
float32 and float64 operations in the same order; a test holds each to its numpy form).
Compiled on first use in a process (about two seconds for the decoders, 1.5-2 more for
the trimmed mean); numba's on-disk cache is not used, since it pickles.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from sassi_bench.maths.order_statistics import select


@njit(nogil=True, inline="always")
def _min_nan(a, b):  # pragma: no cover - compiled
    """``np.minimum``: NaN if either is NaN."""
    if a != a or b != b:
        return a + b
    return a if a < b else b


@njit(nogil=True, inline="always")
def _max_nan(a, b):  # pragma: no cover - compiled
    """``np.maximum``: NaN if either is NaN."""
    if a != a or b != b:
        return a + b
    return a if a > b else b


@njit(nogil=True)
def gray_pair(
    positive, negative, dark, dark_map, mask, word, smallest, second, clipped, saturation
):  # pragma: no cover - compiled
    """One Gray bit and its inverse, folded into the running decode of every pixel.

    ``on = float32(positive) - dark``, ``off`` likewise; the bit's contrast
    ``|on - off| / (on + off)`` (0 where the sum is not positive) updates the smallest and
    second-smallest contrasts, ``on > off`` sets ``mask`` in the pixel's Gray ``word``, and
    a raw value ``>= saturation`` (NaN: no test) sets ``clipped``. ``dark`` is (H, W)
    float32 when ``dark_map``, else its [0, 0] is the level of every pixel. Every update is
    a minimum, a maximum or an OR, so the bits may come in any order.
    """
    height, width = positive.shape
    inf = np.float32(np.inf)
    test = saturation == saturation
    for r in range(height):
        for c in range(width):
            level = dark[r, c] if dark_map else dark[0, 0]
            p = positive[r, c]
            n = negative[r, c]
            on = np.float32(p) - level
            off = np.float32(n) - level
            total = on + off
            contrast = abs(on - off) / (total if total > 0 else inf)
            if on > off:
                word[r, c] |= mask
            low = smallest[r, c]
            second[r, c] = _min_nan(second[r, c], _max_nan(low, contrast))
            smallest[r, c] = _min_nan(low, contrast)
            if test and (p >= saturation or n >= saturation):
                clipped[r, c] = True


@njit(nogil=True)
def gray_index(word, bits):  # pragma: no cover - compiled
    """Binary block index of every Gray word of ``bits`` bits (bit 0 the most significant)."""
    out = np.empty(word.shape, dtype=np.int64)
    height, width = word.shape
    for r in range(height):
        for c in range(width):
            gray = word[r, c]
            binary = 0
            index = 0
            for b in range(bits - 1, -1, -1):
                binary ^= (gray >> b) & 1
                index = (index << 1) | binary
            out[r, c] = index
    return out


@njit(nogil=True)
def saturation_test(frame, saturation, clipped):  # pragma: no cover - compiled
    """``clipped |= frame >= saturation``."""
    height, width = frame.shape
    for r in range(height):
        for c in range(width):
            if frame[r, c] >= saturation:
                clipped[r, c] = True


@njit(nogil=True)
def _phase_row(frames, dark, dark_map, solver, r, a0, a1, a2):  # pragma: no cover - compiled
    """``a_k = sum_s solver[k, s] * (float32(frames[s, r]) - dark)`` over row ``r``, in
    float64, frames in order (as numpy accumulating one float32 frame at a time)."""
    a0[:] = 0.0
    a1[:] = 0.0
    a2[:] = 0.0
    width = a0.size
    for s in range(frames.shape[0]):
        w0, w1, w2 = solver[0, s], solver[1, s], solver[2, s]
        if dark_map:
            for c in range(width):
                value = np.float64(np.float32(frames[s, r, c]) - dark[r, c])
                a0[c] += w0 * value
                a1[c] += w1 * value
                a2[c] += w2 * value
        else:
            level = dark[0, 0]
            for c in range(width):
                value = np.float64(np.float32(frames[s, r, c]) - level)
                a0[c] += w0 * value
                a1[c] += w1 * value
                a2[c] += w2 * value


@njit(nogil=True)
def phase_usable(frames, dark, dark_map, solver, usable):  # pragma: no cover - compiled
    """Pixels whose fitted fringe has a positive offset ``A`` and an amplitude
    ``hypot(a, b) > 0.2 A`` (those the frame gains are fitted on)."""
    height, width = usable.shape
    a0, a1, a2 = np.empty(width), np.empty(width), np.empty(width)
    for r in range(height):
        _phase_row(frames, dark, dark_map, solver, r, a0, a1, a2)
        for c in range(width):
            usable[r, c] = a0[c] > 0 and np.hypot(a1[c], a2[c]) > 0.2 * a0[c]


@njit(nogil=True)
def phase_fit(
    frames, dark, dark_map, solver, period, skip, use_skip, offset, coord, modulation
):  # pragma: no cover - compiled
    """Every pixel's fringe: offset ``A``, position in the period
    ``mod(atan2(b, a) * period / 2 pi, period)`` (0 where that rounds up to the period)
    and amplitude ``hypot(a, b)``. With ``use_skip``, the position is left at 0 where
    ``skip``: the arc tangent is most of the cost, and a pixel too dark to decode does not
    need it."""
    height, width = coord.shape
    scale = period / (2.0 * np.pi)
    a0, a1, a2 = np.empty(width), np.empty(width), np.empty(width)
    for r in range(height):
        _phase_row(frames, dark, dark_map, solver, r, a0, a1, a2)
        for c in range(width):
            offset[r, c] = a0[c]
            modulation[r, c] = np.hypot(a1[c], a2[c])
            if use_skip and skip[r, c]:
                coord[r, c] = 0.0
                continue
            value = np.arctan2(a2[c], a1[c]) * scale
            rest = np.fmod(value, period)  # numpy's modulo: the sign of the divisor
            if rest != 0.0 and (rest < 0.0) != (period < 0.0):
                rest += period
            coord[r, c] = 0.0 if rest >= period else rest


@njit(nogil=True)
def axis_reasons(
    is_dark,
    clipped,
    modulation,
    offset,
    second_margin,
    phase,
    index,
    block,
    period,
    min_modulation,
    min_margin,
    limit,
    coord,
    coarse,
    depth,
    reason,
):  # pragma: no cover - compiled
    """Unwrapped coordinate, Gray block centre, modulation depth and the first of the
    per-pixel reasons 1-5 of ``pixel_validity.REASONS`` (0: none) of every pixel.

    ``depth = modulation / offset`` (0 where the offset is not positive); ``coord`` is the
    phase unwrapped to the block centre ``block * index + (block - 1) / 2``; the tests in
    order: dark, clipped, ``depth < min_modulation``, ``second_margin < min_margin``,
    ``|coord - coarse| > limit``. ``coord`` may be ``phase`` and ``depth`` may be
    ``modulation`` (computed in place).
    """
    height, width = coord.shape
    half = (block - 1) / 2.0
    for r in range(height):
        for c in range(width):
            centre = block * index[r, c] + half
            p = phase[r, c]  # read before coord, which may be the same array
            value = p + period * np.rint((centre - p) / period)
            o = offset[r, c]
            d = modulation[r, c] / o if o > 0 else 0.0  # likewise depth
            coarse[r, c] = centre
            coord[r, c] = value
            depth[r, c] = d
            code = 0
            if is_dark[r, c]:
                code = 1
            elif clipped[r, c]:
                code = 2
            elif not d >= min_modulation:
                code = 3
            elif second_margin[r, c] < min_margin:
                code = 4
            elif abs(value - centre) > limit:
                code = 5
            reason[r, c] = code


@njit(nogil=True)
def edge_reasons(coord, reason, low, high):  # pragma: no cover - compiled
    """Reason 6 (``edge``) where a pixel without another reason lies outside
    ``[low, high]``."""
    height, width = coord.shape
    for r in range(height):
        for c in range(width):
            if reason[r, c] == 0:
                value = coord[r, c]
                if value < low or value > high:
                    reason[r, c] = 6


@njit(nogil=True)
def plane_sums(coord, reason):  # pragma: no cover - compiled
    """Normal equations of a plane ``a col + b row + c`` through ``coord`` where ``reason``
    is 0: the (3, 3) matrix and (3,) right side, in float64, and the pixel count."""
    matrix = np.zeros((3, 3))
    rhs = np.zeros(3)
    count = 0
    height, width = coord.shape
    for r in range(height):
        sx = 0.0
        sxx = 0.0
        sv = 0.0
        sxv = 0.0
        n = 0
        for c in range(width):
            if reason[r, c] == 0:
                x = float(c)
                v = coord[r, c]
                sx += x
                sxx += x * x
                sv += v
                sxv += x * v
                n += 1
        if n:
            y = float(r)
            matrix[0, 0] += sxx
            matrix[0, 1] += y * sx
            matrix[0, 2] += sx
            matrix[1, 1] += y * y * n
            matrix[1, 2] += y * n
            matrix[2, 2] += n
            rhs[0] += sxv
            rhs[1] += y * sv
            rhs[2] += sv
            count += n
    matrix[1, 0] = matrix[0, 1]
    matrix[2, 0] = matrix[0, 2]
    matrix[2, 1] = matrix[1, 2]
    return matrix, rhs, count


@njit(nogil=True)
def plane_residual(coord, reason, plane, padded, half):  # pragma: no cover - compiled
    """``padded[r + half, c + half] = float32(coord - plane)`` where ``reason`` is 0,
    ``inf`` elsewhere and in the border of ``half`` pixels."""
    height, width = coord.shape
    padded[:, :] = np.inf
    a, b, k = plane[0], plane[1], plane[2]
    for r in range(height):
        for c in range(width):
            if reason[r, c] == 0:
                padded[r + half, c + half] = np.float32(coord[r, c] - (c * a + r * b + k))


@njit(nogil=True)
def window_outliers(padded, reason, size, max_jump, min_neighbours):  # pragma: no cover
    """Set ``reason`` to 7 where a passed pixel lies more than ``max_jump`` from the median
    of the finite values of its ``size`` x ``size`` window (itself included), judged only
    with at least ``min_neighbours`` others; returns how many.

    The median is float32 ``0.5 * (lower + upper middle value)``, as a sort gives it. When
    more than half of the window's k values lie within ``max_jump / 2`` of the pixel, both
    middle values do (fewer than half lie on either side of that interval), so the pixel
    is kept without sorting; otherwise the window is sorted.
    """
    height, width = reason.shape
    half = size // 2
    buffer = np.empty(size * size, dtype=np.float32)
    near = 0.5 * max_jump
    found = 0
    for r in range(height):
        for c in range(width):
            if reason[r, c] != 0:
                continue
            own = padded[r + half, c + half]
            k = 0
            close = 0
            for i in range(size):
                for j in range(size):
                    value = padded[r + i, c + j]
                    if abs(value) < np.inf:
                        k += 1
                        close += abs(np.float64(value) - np.float64(own)) <= near
            if k - 1 < min_neighbours or 2 * close > k:
                continue
            k = 0
            for i in range(size):
                for j in range(size):
                    value = padded[r + i, c + j]
                    if abs(value) < np.inf:
                        m = k  # insertion sort
                        while m > 0 and buffer[m - 1] > value:
                            buffer[m] = buffer[m - 1]
                            m -= 1
                        buffer[m] = value
                        k += 1
            median = np.float32(0.5) * (buffer[(k - 1) // 2] + buffer[k // 2])
            if abs(own - median) > max_jump:
                reason[r, c] = 7
                found += 1
    return found


@njit(nogil=True)
def accumulate(frame, total):  # pragma: no cover - compiled
    """``total += float32(frame)`` (a float32 running sum, as numpy's along a stack)."""
    height, width = frame.shape
    for r in range(height):
        for c in range(width):
            total[r, c] += np.float32(frame[r, c])


@njit(nogil=True)
def frame_moments(frames, mean, variance):  # pragma: no cover - compiled
    """Per pixel, the mean and the variance (ddof 1; 0 for one frame) of (F, H, W) frames
    in float64, as numpy's ``mean(0)`` and ``var(0, ddof=1)`` of the float64 stack (sums
    in frame order, the variance about the mean), without that stack."""
    count, height, width = frames.shape
    for r in range(height):
        for c in range(width):
            total = 0.0
            for f in range(count):
                total += np.float64(frames[f, r, c])
            centre = total / count
            square = 0.0
            for f in range(count):
                d = np.float64(frames[f, r, c]) - centre
                square += d * d
            mean[r, c] = centre
            variance[r, c] = square / (count - 1) if count > 1 else 0.0


@njit(nogil=True)
def _ratio(frame, lit, dark, low, span, i):  # pragma: no cover - compiled
    """``(frame[lit[i]] - dark - low) / span`` in float64, as numpy's over the lit pixels."""
    j = lit[i]
    level = dark[0] if dark.size == 1 else dark[i]
    return ((np.float64(frame[j]) - level) - low[i]) / span[i]


@njit(nogil=True)
def _chunked_sum(values, start, stop):  # pragma: no cover - compiled
    """``values[start:stop].sum()`` in chunks of 4096 (rounding near numpy's pairwise)."""
    total = 0.0
    for first in range(start, stop, 4096):
        chunk = 0.0
        for i in range(first, min(first + 4096, stop)):
            chunk += values[i]
        total += chunk
    return total


@njit(nogil=True)
def _bracket(sample, m, rank, n, width):  # pragma: no cover - compiled
    """The sample values ``width`` standard errors either side of the full set's ``rank``
    (``-inf`` or ``inf`` past the sample's ends)."""
    q = rank / n
    at = q * (m - 1)
    reach = width * np.sqrt(m * q * (1.0 - q)) + 2.0
    below, above = int(np.floor(at - reach)), int(np.ceil(at + reach))
    low = select(sample, m, below) if below >= 0 else -np.inf
    high = select(sample, m, above) if above < m else np.inf
    return low, high


@njit(nogil=True)
def trimmed_ratio_mean(frame, lit, dark, low, span, lowercut, step, width):  # pragma: no cover
    """Trimmed mean and standard deviation of ``(frame[lit] - dark - low) / span`` without
    sorting or storing those ratios: scipy's ``trim_mean(ratio, lowercut / n)``, which
    partitions all ``n`` of them, to rounding (the same values kept, summed in another
    order).

    A strided sample (every ``step``-th ratio) brackets the two cut points' values to
    ``width`` sample standard errors of their ranks; one pass then counts the ratios
    below the lower band and above the upper one, sums those between the bands and keeps
    the few inside the bands, whose partition places the cuts exactly. ``frame`` is the
    flat raw frame, ``lit`` the flat indices used, ``dark`` per lit pixel (or one value),
    ``low`` and ``span`` per lit pixel. Returns ``(mean, std, ok)``; ``ok`` is False when
    the bands missed a cut, overlapped or overflowed, or a ratio is not finite: then the
    caller computes the ratios and partitions them.
    """
    n = lit.size
    upper_cut = n - lowercut
    m = (n + step - 1) // step
    sample = np.empty(m)
    for s in range(m):
        sample[s] = _ratio(frame, lit, dark, low, span, s * step)
    for s in range(m):
        if not np.isfinite(sample[s]):
            return 0.0, 0.0, False
    centre = select(sample, m, m // 2)
    lo_a, lo_b = _bracket(sample, m, lowercut, n, width)
    hi_a, hi_b = _bracket(sample, m, upper_cut - 1, n, width)
    if not lo_b < hi_a:
        return 0.0, 0.0, False
    # A band holds about 2 width sqrt(n step q (1 - q)) ratios: room for four times that
    # and a chunk (every value of a chunk is written before the count keeps it or not).
    capacity = min(int(8.0 * width * np.sqrt(n * step * 0.25)) + 8 * step, n) + 4096
    lo_band, hi_band = np.empty(capacity), np.empty(capacity)
    n_lo = n_lo_band = n_mid = n_hi_band = 0
    shifted = square = middle = 0.0
    chunk = np.empty(4096)
    # Chunks of 4096: the counts and sums are selects, not branches (a ratio's class is
    # random from pixel to pixel), and the chunk sums keep the rounding near numpy's
    # pairwise sum; the rare band values are picked from the chunk afterwards.
    for start in range(0, n, 4096):
        stop = min(start + 4096, n)
        block = 0.0
        for i in range(start, stop):
            x = _ratio(frame, lit, dark, low, span, i)
            chunk[i - start] = x
            d = x - centre
            shifted += d
            square += d * d
            n_lo += x < lo_a
            inside = (x > lo_b) & (x < hi_a)
            block += x if inside else 0.0
            n_mid += inside
        middle += block
        if max(n_lo_band, n_hi_band) + (stop - start) > capacity:
            return 0.0, 0.0, False
        for i in range(stop - start):  # every value written, the count kept if in a band
            x = chunk[i]
            lo_band[n_lo_band] = x
            n_lo_band += (x >= lo_a) & (x <= lo_b)
            hi_band[n_hi_band] = x
            n_hi_band += (x >= hi_a) & (x <= hi_b)
    if not np.isfinite(shifted):  # a NaN or infinite ratio
        return 0.0, 0.0, False
    first = lowercut - n_lo  # the lower cut's position in the lower band
    last = upper_cut - 1 - (n_lo + n_lo_band + n_mid)  # the upper cut's in the upper band
    if not (0 <= first < n_lo_band and 0 <= last < n_hi_band):
        return 0.0, 0.0, False
    select(lo_band, n_lo_band, first)  # the band's values from the cut on are kept
    select(hi_band, n_hi_band, last)  # and those up to the cut
    total = middle + _chunked_sum(lo_band, first, n_lo_band) + _chunked_sum(hi_band, 0, last + 1)
    variance = (square - shifted * shifted / n) / n
    return total / (upper_cut - lowercut), np.sqrt(max(variance, 0.0)), True
