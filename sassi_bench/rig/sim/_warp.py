"""The dense renderer's compiled loops (numba): full-resolution maps, label images.

:func:`upsample_maps` interpolates the coarse inverse map and area ratio (nodes every
``step`` camera px) bilinearly onto the camera rows a frame's light reaches: within a
grid cell they are linear along a row, so they are stepped: only the rows reached, and
no dense matrix products over the whole frame
(``docs/notes/2026-12-01-measured-in-code-comments.md``). :func:`label_image` makes a label scene's
SLM image at one wavelength (transmission times the label's reflectance) in one pass.

Rows are split over threads by ``prange``; every output pixel is computed by one thread
from the same inputs, so the results do not depend on the number of threads.

No on-disk cache: numba's cache pickles into the package folder.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

__all__ = ["label_image", "upsample_maps"]


@njit(parallel=True, error_model="numpy", cache=False)
def label_image(transmission, labels, values, out):  # pragma: no cover - compiled
    """``out = transmission * values[labels]`` (a label scene's SLM image at one
    wavelength), in float32."""
    rows, cols = out.shape
    for i in prange(rows):
        line, shown, label = out[i], transmission[i], labels[i]
        for j in range(cols):
            # An unsigned label: numba then adds no test for a negative index, and the
            # gather vectorises.
            line[j] = shown[j] * values[np.uint64(label[j])]


@njit(parallel=True, error_model="numpy", cache=False)
def upsample_maps(map_u, map_v, map_area, step, row0, out_u, out_v, out_area):  # pragma: no cover
    """The coarse inverse map and area ratio at every camera pixel of a band of rows.

    Parameters
    ----------
    map_u, map_v, map_area
        (Ny, Nx) coarse maps; node (a, b) is at camera (x, y) = ((b - 1) * step,
        (a - 1) * step), and the grid covers the frame.
    step
        Coarse grid spacing, camera px (an integer).
    row0
        Camera row of the band's first row.
    out_u, out_v, out_area
        (rows, Wc) float32, overwritten: the bilinear interpolation of the maps.
    """
    rows, cols = out_u.shape
    inv_step = 1.0 / step
    ny, nx = map_u.shape
    istep = int(step)
    for i in prange(rows):
        fy = (row0 + i) * inv_step + 1.0
        a = min(int(fy), ny - 2)
        ty = fy - a
        line_u, line_v, line_area = out_u[i], out_v[i], out_area[i]
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
            # Slices indexed from 0: numba then adds no test for a negative index.
            cell_u = line_u[first:stop]
            cell_v = line_v[first:stop]
            cell_area = line_area[first:stop]
            for t in range(stop - first):
                d = t + first - j0
                cell_u[t] = u0 + du * d
                cell_v[t] = v0 + dv * d
                cell_area[t] = s0 + ds * d
