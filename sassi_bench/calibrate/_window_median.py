"""The outlier screen's compiled loop (numba): each pixel's median over its window.

:func:`~sassi_bench.calibrate.pixel_validity.local_outliers` needs, for every valid
pixel, the median of the finite values in the 5 x 5 window around it. As numpy that
gathered an (N, 25) float32 array of windows (200 MB at the prototype's 2M valid pixels)
and sorted it; here each window is sorted in a small buffer, pixels in parallel (each
pixel's result is its own, so the output does not depend on the threads).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(parallel=True)
def window_medians(padded, rows, cols, size):  # pragma: no cover
    """Median and count of the finite values of each ``size`` x ``size`` window.

    Parameters
    ----------
    padded
        (H + size - 1, W + size - 1) float32, non-finite where a pixel does not count.
    rows, cols
        Top-left corners of the windows in ``padded`` (the pixels' own coordinates).
    size
        Window side.

    Returns
    -------
    median, count
        (N,) float32 median (mean of the two middle values for an even count; NaN when no
        value counts) and (N,) int64 count of finite values.
    """
    n = rows.size
    median = np.empty(n, dtype=np.float32)
    count = np.zeros(n, dtype=np.int64)
    for p in prange(n):
        buffer = np.empty(size * size, dtype=np.float32)
        k = 0
        for i in range(size):
            for j in range(size):
                value = padded[rows[p] + i, cols[p] + j]
                if np.isfinite(value):
                    m = k  # insertion sort
                    while m > 0 and buffer[m - 1] > value:
                        buffer[m] = buffer[m - 1]
                        m -= 1
                    buffer[m] = value
                    k += 1
        count[p] = k
        if k == 0:
            median[p] = np.nan
        else:
            median[p] = np.float32(0.5) * (buffer[(k - 1) // 2] + buffer[k // 2])
    return median, count
