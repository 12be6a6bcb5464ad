"""The dense renderer's compiled loops (numba): one wavelength sample's SLM image, warped.

For every camera pixel of a band of rows, the inverse map (u, v) and the area ratio are
interpolated bilinearly from their coarse grid (nodes every ``step`` camera px: within a
grid cell they are linear along a row, so they are stepped), and the SLM image is
sampled bilinearly at (u, v) (zero outside the SLM), times the area ratio and the
sample's gain. This replaces up-sampling the three coarse maps to full frames (three
dense matrix products, 67 ms a map at the prototype's 2048 x 2048) and ``cv2.remap``
(which rounds map positions to 1/32 px): at the prototype's scale a sample's warp takes
about 11 ms of CPU against 40 before (25 with the laser's full-size maps kept, 3 x 16
MB a sample), and no full-size map is held.

Rows are split over threads by ``prange``; every output pixel is computed by one thread
from the same inputs, so the frame does not depend on the number of threads.

No on-disk cache: numba's cache pickles into the package folder.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["label_image", "warp_sample"]


@njit(parallel=True, error_model="numpy", cache=False)
def label_image(transmission, labels, values, out):  # pragma: no cover - compiled
    """``out = transmission * values[labels]`` (a label scene's SLM image at one
    wavelength), in float32."""
    rows, cols = out.shape
    for i in prange(rows):
        for j in range(cols):
            out[i, j] = transmission[i, j] * values[labels[i, j]]


@njit(parallel=True, error_model="numpy", cache=False)
def warp_sample(
    source, map_u, map_v, map_area, step, gain, row0, out
):  # pragma: no cover - compiled
    """Write one sample's warped SLM image into ``out`` (camera rows ``row0`` onwards).

    Parameters
    ----------
    source
        (H, W) float32 SLM image (transmission times reflectance).
    map_u, map_v, map_area
        (Ny, Nx) coarse inverse map and area ratio; node (a, b) is at camera
        (x, y) = ((b - 1) * step, (a - 1) * step), and the grid covers the frame.
    step
        Coarse grid spacing, camera px (an integer).
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
    istep = int(step)
    for i in prange(rows):
        fy = (row0 + i) * inv_step + 1.0
        a = min(int(fy), ny - 2)
        ty = fy - a
        for b in range(nx - 1):
            j0 = (b - 1) * istep  # camera column of node b
            first = max(j0, 0)
            stop = min(j0 + istep, cols)
            if first >= stop:
                continue
            u0 = (1.0 - ty) * map_u[a, b] + ty * map_u[a + 1, b]
            v0 = (1.0 - ty) * map_v[a, b] + ty * map_v[a + 1, b]
            s0 = (1.0 - ty) * map_area[a, b] + ty * map_area[a + 1, b]
            du = ((1.0 - ty) * map_u[a, b + 1] + ty * map_u[a + 1, b + 1] - u0) * inv_step
            dv = ((1.0 - ty) * map_v[a, b + 1] + ty * map_v[a + 1, b + 1] - v0) * inv_step
            ds = ((1.0 - ty) * map_area[a, b + 1] + ty * map_area[a + 1, b + 1] - s0) * inv_step
            for j in range(first, stop):
                t = j - j0
                u = u0 + du * t
                v = v0 + dv * t
                value = 0.0
                if u > -1.0 and v > -1.0 and u < width and v < height:
                    c0 = int(np.floor(u))
                    r0 = int(np.floor(v))
                    fu = u - c0
                    fv = v - r0
                    if c0 >= 0 and r0 >= 0 and c0 + 1 < width and r0 + 1 < height:
                        value = (1.0 - fv) * (
                            (1.0 - fu) * source[r0, c0] + fu * source[r0, c0 + 1]
                        ) + fv * ((1.0 - fu) * source[r0 + 1, c0] + fu * source[r0 + 1, c0 + 1])
                    else:  # at the SLM's edge: the corners outside it are dark
                        for dr in range(2):
                            r = r0 + dr
                            if r < 0 or r >= height:
                                continue
                            wr = fv if dr else 1.0 - fv
                            for dc in range(2):
                                c = c0 + dc
                                if 0 <= c < width:
                                    value += wr * (fu if dc else 1.0 - fu) * source[r, c]
                    value *= (s0 + ds * t) * gain
                out[i, j] = value
