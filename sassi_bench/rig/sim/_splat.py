"""The sparse renderer's compiled loop (numba): every open pixel's streak into the frame.

Each (open pixel, wavelength sample) deposits a separable spot, ``w * ty[i] * tx[j]``,
where ``ty`` and ``tx`` are rows of a table of spot profiles
(:class:`~sassi_bench.rig.sim.render.SpectralRenderer`'s ``_SpotTable``) already sampled
at whole-pixel taps for each 1/64 px sub-pixel phase and normalised to sum to 1, so each
spot deposits exactly its weight. A spot is a few hundred multiply-adds straight into
the frame, along contiguous rows of the table and of the frame (float32, vectorised).

The frame is cut into horizontal bands, one task each; a task adds only the spots' rows
inside its band, visiting the (pixel, sample) pairs in order. Every frame pixel so
receives its terms in the same order whatever the number of threads, and the frame is
the same bit for bit on every machine.

Measured (sim-prototype, 4320 open pixels x 166 samples of the LED, about 280 M
multiply-adds): 140 ms of CPU with the profiles read at a stride of 64 table entries per
tap and summed in float64, XX ms with contiguous phase-major taps in float32. As numpy
the same splat needed batched matrix products into per-pixel patches and a ``bincount``
into a fresh full frame per block of pixels (0.53 s).

Compiled on first use in a process (a few seconds); numba's on-disk cache is not used
(it pickles into the package folder).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

#: Horizontal bands of the frame, one task each (a constant, so that results do not
#: depend on the machine).
BANDS = 32


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
        (K, steps, T) float32: ``taps[k, phase, t]`` is sample k's profile at whole-pixel
        offset ``t - reach[k] - phase / steps`` from a centre at sub-pixel ``phase``
        (centres are rounded to ``1 / steps`` px), normalised to sum to 1 over ``t``;
        ``t`` runs over ``0 .. 2 reach[k]``, and the entries after it are 0 up to T, a
        multiple of 8 above ``2 max(reach)``.
    out
        The frame (float32), added to in place.
    """
    height, width = out.shape
    n_pix, n_lam = x.shape
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
            for k in range(n_lam):
                w = weights[p, k]
                if w == 0.0:
                    continue
                r = reach[k]
                iy = np.int64(np.rint(y[p, k] * steps))
                cy = iy // steps
                top = max(cy - r, first)
                bottom = min(cy + r, last)
                if top > bottom:
                    continue
                ix = np.int64(np.rint(x[p, k] * steps))
                cx = ix // steps
                left = cx - r
                ty = taps[k, iy - cy * steps]
                # The taps run on, as zeros, to a multiple of 8: a row is whole float32
                # vectors, without a scalar remainder (slices indexed from 0 also tell
                # numba that no index is negative, so it tests for no wrap-around).
                whole = (2 * r + 8) // 8 * 8
                if left >= 0 and left + whole <= width:
                    tx = taps[k, ix - cx * steps, :whole]
                    for i in range(top, bottom + 1):
                        a = w * ty[i - cy + r]
                        row = out[i, left : left + whole]
                        for j in range(whole):
                            row[j] += a * tx[j]
                else:  # the frame's edge cuts the spot
                    start = max(0, -left)
                    stop = min(2 * r + 1, width - left)
                    if start >= stop:
                        continue
                    tx = taps[k, ix - cx * steps, start:stop]
                    for i in range(top, bottom + 1):
                        a = w * ty[i - cy + r]
                        row = out[i, left + start : left + stop]
                        for j in range(stop - start):
                            row[j] += a * tx[j]
