"""The sparse renderer's compiled loop (numba): every open pixel's streak into the frame.

Each (open pixel, wavelength sample) deposits a separable spot, ``gy[i] * gx[j]``, read
from a table of spot profiles (:class:`~sassi_bench.rig.sim.render.SpectralRenderer`'s
``_SpotTable``): a few hundred multiply-adds straight into the frame. As numpy the same
splat needed batched matrix products into per-pixel patches and a ``bincount`` into a
fresh full frame per block of pixels, 0.53 s CPU for a 100 x 5 pinhole frame under a
broadband light at the sim-prototype scale (4320 pixels x 166 samples); compiled it takes
a fifth of that.

The frame is cut into horizontal bands, one task each; a task adds only the spots' rows
inside its band, visiting the (pixel, sample) pairs in order. Every frame pixel so
receives its terms in the same order whatever the number of threads, and the frame is
the same bit for bit on every machine.

Compiled on first use in a process (a few seconds); numba's on-disk cache is not used
(it pickles into the package folder).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

#: Horizontal bands of the frame, one task each (a constant, so that results do not
#: depend on the machine).
BANDS = 32


@njit(parallel=True, error_model="numpy")
def splat(x, y, weights, values, centre, steps, norm, reach, out):  # pragma: no cover
    """Add the spots of ``weights`` (P, K) at positions ``x, y`` (P, K) into ``out`` (H, W).

    Parameters
    ----------
    x, y
        Spot centres, camera px (P pixels, K wavelength samples).
    weights
        Energy of each spot (electrons per second).
    values
        Spot profiles (K, T): ``values[k, centre + m]`` at ``m / steps`` px from the centre,
        zero beyond ``reach[k]`` px.
    norm
        (K, steps): the profile's sum over whole-pixel taps for each sub-pixel phase, by
        which each spot is divided so that it deposits exactly its weight.
    out
        The frame (float64), added to in place.
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
        gx = np.empty(2 * widest + 1)
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
                left = max(cx - r, 0)
                right = min(cx + r, width - 1)
                if left > right:
                    continue
                scale = w / (norm[k, ix % steps] * norm[k, iy % steps])
                taps = right - left + 1
                for j in range(taps):  # the x profile, contiguous for the row loop
                    gx[j] = values[k, centre + (left + j) * steps - ix]
                for i in range(top, bottom + 1):
                    gy = values[k, centre + i * steps - iy] * scale
                    if gy == 0.0:
                        continue
                    row = out[i, left : right + 1]
                    for j in range(taps):
                        row[j] += gy * gx[j]
