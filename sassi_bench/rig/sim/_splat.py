"""The sparse renderer's compiled loop (numba): every open pixel's streak into the frame.

Each (open pixel, wavelength sample) deposits a separable spot, ``w * ty[i] * tx[j]``,
where ``ty`` and ``tx`` are rows of a table of spot profiles
(:class:`~sassi_bench.rig.sim.render.SpectralRenderer`'s ``_SpotTable``, laid out by
:func:`table_width`) already sampled at whole-pixel taps for each 1/64 px sub-pixel phase
and normalised to sum to 1, so each spot deposits exactly its weight. A spot is a few
hundred multiply-adds straight into the frame, along contiguous rows of the table and
of the frame, in float32 vectors.

Two neighbouring samples of a pixel are deposited together, ``row[j] += a0 tx0[j] +
a1 tx1[j]`` over the union of their windows (the taps padded with zeros on both sides,
so one sample's taps read 0 where only the other's reach): their spots overlap almost
entirely, and one pass over the frame's row instead of two is what the loop is bound by.

The frame is cut into horizontal bands, one task each; a task adds only the spots' rows
inside its band, visiting the (pixel, sample) pairs in order. Every frame pixel so
receives its terms in the same order whatever the number of threads, and the frame is
the same bit for bit on every machine.

The taps are contiguous, pre-normalised float32, padded to whole vectors, and samples
are deposited in pairs: each of these cut the splat's CPU, and as numpy the same splat
needs batched matrix products into per-pixel patches and a ``bincount`` into a fresh full
frame per block of pixels (``docs/notes/2026-12-01-measured-in-code-comments.md``).

Compiled on first use in a process (a few seconds); numba's on-disk cache is not used
(it pickles into the package folder).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["BANDS", "PAD", "splat", "table_width"]

#: Horizontal bands of the frame, one task each (a constant, so that results do not
#: depend on the machine).
BANDS = 32
#: Zeros before a profile's taps in the table (and at least as many after).
PAD = 8


def table_width(max_reach: int) -> int:
    """Entries per (sample, phase) row of the taps table for reaches up to ``max_reach``:
    :data:`PAD` zeros, ``2 max_reach + 1`` taps, and zeros to a multiple of 8 with room
    for a pair's union window.

    Examples
    --------
    >>> table_width(5)
    48
    """
    return (2 * PAD + 2 * max_reach + 16 + 7) // 8 * 8


@njit(inline="always", error_model="numpy")
def _spot(x, y, weights, taps, reach, steps, p, k):  # pragma: no cover - compiled
    """Pixel p's sample k: weight, reach, centre pixel (cy, cx) and the row and column
    taps of its sub-pixel phases."""
    iy = np.int64(np.rint(y[p, k] * steps))
    cy = iy // steps
    ix = np.int64(np.rint(x[p, k] * steps))
    cx = ix // steps
    return weights[p, k], reach[k], cy, cx, taps[k, iy - cy * steps], taps[k, ix - cx * steps]


@njit(inline="always", error_model="numpy")
def _deposit(w, r, cy, cx, ty, tx_row, first, last, out):  # pragma: no cover - compiled
    """One spot: ``w * ty * tx`` at centre pixel (cx, cy), rows [first, last] only."""
    width = out.shape[1]
    top = max(cy - r, first)
    bottom = min(cy + r, last)
    left = cx - r
    # The taps run on, as zeros, to a multiple of 8: a row is whole float32 vectors,
    # without a scalar remainder (slices indexed from 0 also tell numba that no index
    # is negative, so it tests for no wrap-around).
    whole = (2 * r + 8) // 8 * 8
    if left >= 0 and left + whole <= width:
        tx = tx_row[PAD : PAD + whole]
        for i in range(top, bottom + 1):
            a = w * ty[PAD + i - cy + r]
            row = out[i, left : left + whole]
            for j in range(whole):
                row[j] += a * tx[j]
    else:  # the frame's edge cuts the spot
        start = max(0, -left)
        stop = min(2 * r + 1, width - left)
        if start >= stop:
            return
        tx = tx_row[PAD + start : PAD + stop]
        for i in range(top, bottom + 1):
            a = w * ty[PAD + i - cy + r]
            row = out[i, left + start : left + stop]
            for j in range(stop - start):
                row[j] += a * tx[j]


@njit(parallel=True, error_model="numpy", cache=False)
def splat(x, y, weights, taps, reach, steps, out):  # pragma: no cover - compiled
    """Add the spots of ``weights`` (P, K) at positions ``x, y`` (P, K) into ``out`` (H, W).

    Parameters
    ----------
    x, y
        Spot centres, camera px (P pixels, K wavelength samples).
    weights
        Energy of each spot (float32, electrons per second).
    taps
        (K, steps, T) float32: ``taps[k, phase, PAD + t]`` is sample k's profile at
        whole-pixel offset ``t - reach[k] - phase / steps`` from a centre at sub-pixel
        ``phase`` (centres are rounded to ``1 / steps`` px), normalised to sum to 1 over
        ``t`` in ``0 .. 2 reach[k]``; every other entry is 0, and ``T`` is
        :func:`table_width` of the largest reach.
    reach
        (K,) int64: each sample's reach, px.
    out
        The frame (float32), added to in place.
    """
    height, width = out.shape
    n_pix, n_lam = x.shape
    size = taps.shape[2]
    rows_per_band = (height + BANDS - 1) // BANDS
    widest = 0
    for k in range(n_lam):
        widest = max(widest, reach[k])
    # Each pixel's streak's rows (they vary by about a pixel), once for every band.
    lowest = np.empty(n_pix)
    highest = np.empty(n_pix)
    for p in range(n_pix):
        low, high = y[p, 0], y[p, 0]
        for k in range(1, n_lam):
            low = min(low, y[p, k])
            high = max(high, y[p, k])
        lowest[p] = low
        highest[p] = high
    for band in prange(BANDS):
        first = band * rows_per_band
        last = min(height, first + rows_per_band) - 1
        for p in range(n_pix):
            # Skip a pixel whose whole streak misses the band.
            if highest[p] + widest + 1 < first or lowest[p] - widest - 1 > last:
                continue
            for k0 in range(0, n_lam, 2):
                w0, r0, cy0, cx0, ty0, tx0 = _spot(x, y, weights, taps, reach, steps, p, k0)
                in0 = w0 != 0.0 and cy0 - r0 <= last and cy0 + r0 >= first
                k1 = min(k0 + 1, n_lam - 1)  # an odd last sample pairs with none
                w1, r1, cy1, cx1, ty1, tx1 = _spot(x, y, weights, taps, reach, steps, p, k1)
                in1 = k1 > k0 and w1 != 0.0 and cy1 - r1 <= last and cy1 + r1 >= first
                if in0 and in1:
                    # The pair's union window, in the frame and in each one's taps.
                    left = min(cx0 - r0, cx1 - r1)
                    whole = (max(cx0 + r0, cx1 + r1) - left + 8) // 8 * 8
                    s0 = PAD - (cx0 - r0 - left)
                    s1 = PAD - (cx1 - r1 - left)
                    top = max(min(cy0 - r0, cy1 - r1), first)
                    bottom = min(max(cy0 + r0, cy1 + r1), last)
                    o0 = PAD - (cy0 - r0)  # ty0[o0 + i] is row i's
                    o1 = PAD - (cy1 - r1)
                    if (
                        left >= 0
                        and left + whole <= width
                        and min(s0, s1) >= 0
                        and max(s0, s1) + whole <= size
                        and min(o0, o1) + top >= 0
                        and max(o0, o1) + bottom < size
                    ):
                        a_taps = tx0[s0 : s0 + whole]
                        b_taps = tx1[s1 : s1 + whole]
                        for i in range(top, bottom + 1):
                            a = w0 * ty0[o0 + i]
                            b = w1 * ty1[o1 + i]
                            row = out[i, left : left + whole]
                            for j in range(whole):
                                row[j] += a * a_taps[j] + b * b_taps[j]
                        continue
                if in0:
                    _deposit(w0, r0, cy0, cx0, ty0, tx0, first, last, out)
                if in1:
                    _deposit(w1, r1, cy1, cx1, ty1, tx1, first, last, out)
