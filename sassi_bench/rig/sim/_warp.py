"""The dense renderer's compiled loop (numba): one wavelength sample's SLM image, warped.

For every camera pixel of a band of rows, the inverse map (u, v) and the area ratio are
interpolated bilinearly from their coarse grid (nodes every ``step`` camera px), and the
SLM image is sampled bilinearly at (u, v) (zero outside the SLM), times the area ratio
and the sample's gain. This replaces up-sampling the three coarse maps to full frames
(three dense matrix products, 67 ms a map at the prototype's 2048 x 2048) and
``cv2.remap`` (which rounds map positions to 1/32 px): at the prototype's scale one
sample of a laser frame takes about 8 ms of CPU instead of 40 (with its maps kept, 25),
and no full-size map is held.

The SLM image is ``source[r, c] * values[labels[r, c]]`` (a label scene's reflectance per
label times the transmission) or ``source[r, c] * values[0]``. The rows of the band are
split over threads by ``prange``; every output pixel is computed by one thread from the
same inputs, so the frame does not depend on the number of threads.

No on-disk cache: numba's cache pickles into the package folder.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["warp_sample"]


@njit(parallel=True, error_model="numpy", cache=False)
def warp_sample(
    source, labels, values, use_labels, map_u, map_v, map_area, step, gain, row0, out
):  # pragma: no cover - compiled
    """Write one sample's warped SLM image into ``out`` (camera rows ``row0`` onwards).

    Parameters
    ----------
    source
        (H, W) float32 SLM image (the transmission, or transmission times reflectance).
    labels, values, use_labels
        With ``use_labels``, pixel (r, c) is scaled by ``values[labels[r, c]]``, else by
        ``values[0]``.
    map_u, map_v, map_area
        (Ny, Nx) float64 coarse inverse map and area ratio; node (a, b) is at camera
        (x, y) = ((b - 1) * step, (a - 1) * step).
    step
        Coarse grid spacing, camera px.
    gain
        The sample's electrons per photon.
    row0
        Camera row of ``out[0]``.
    out
        (rows, Wc) float32, overwritten.
    """
    height, width = source.shape
    rows, cols = out.shape
    inv_step = 1.0 / step
    ny, nx = map_u.shape
    for i in prange(rows):
        fy = (row0 + i) * inv_step + 1.0
        a = min(int(fy), ny - 2)
        ty = fy - a
        # The coarse maps blended along y for this row; along x per pixel below.
        row_u = np.empty(nx)
        row_v = np.empty(nx)
        row_area = np.empty(nx)
        for b in range(nx):
            row_u[b] = (1.0 - ty) * map_u[a, b] + ty * map_u[a + 1, b]
            row_v[b] = (1.0 - ty) * map_v[a, b] + ty * map_v[a + 1, b]
            row_area[b] = (1.0 - ty) * map_area[a, b] + ty * map_area[a + 1, b]
        for j in range(cols):
            fx = j * inv_step + 1.0
            b = min(int(fx), nx - 2)
            tx = fx - b
            u = (1.0 - tx) * row_u[b] + tx * row_u[b + 1]
            v = (1.0 - tx) * row_v[b] + tx * row_v[b + 1]
            value = 0.0
            if u > -1.0 and v > -1.0 and u < width and v < height:
                c0 = int(np.floor(u))
                r0 = int(np.floor(v))
                du = u - c0
                dv = v - r0
                if c0 >= 0 and r0 >= 0 and c0 + 1 < width and r0 + 1 < height:
                    p00 = np.float64(source[r0, c0])
                    p01 = np.float64(source[r0, c0 + 1])
                    p10 = np.float64(source[r0 + 1, c0])
                    p11 = np.float64(source[r0 + 1, c0 + 1])
                    if use_labels:
                        p00 *= values[labels[r0, c0]]
                        p01 *= values[labels[r0, c0 + 1]]
                        p10 *= values[labels[r0 + 1, c0]]
                        p11 *= values[labels[r0 + 1, c0 + 1]]
                    value = (1.0 - dv) * ((1.0 - du) * p00 + du * p01) + dv * (
                        (1.0 - du) * p10 + du * p11
                    )
                else:  # at the SLM's edge: corners outside it are dark
                    for dr in range(2):
                        r = r0 + dr
                        if r < 0 or r >= height:
                            continue
                        wr = dv if dr else 1.0 - dv
                        for dc in range(2):
                            c = c0 + dc
                            if c < 0 or c >= width:
                                continue
                            wc = du if dc else 1.0 - du
                            pixel = np.float64(source[r, c])
                            if use_labels:
                                pixel *= values[labels[r, c]]
                            value += wr * wc * pixel
                if not use_labels:
                    value *= values[0]
                value *= ((1.0 - tx) * row_area[b] + tx * row_area[b + 1]) * gain
            out[i, j] = value
