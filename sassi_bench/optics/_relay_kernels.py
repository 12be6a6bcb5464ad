"""The relay's ray trace as a compiled loop (numba), for many rays at once.

:meth:`~sassi_bench.optics.relay.SpectralRelay.forward` traces a ray in about 80 flops
(the SLM pixel's collimated direction, two refractions by Snell's law, the camera lens
and its distortion). As numpy the trace of the sparse renderer's (open pixel, wavelength
sample) pairs needs a dozen temporaries of the broadcast shape and 3 x 3 matrix products
on rows of 3; compiled, the pixel's direction is made once for all its wavelengths and a
ray costs a few of its operations
(``docs/notes/2026-12-01-measured-in-code-comments.md``).
The same arithmetic, in the same order, is one inlined function (:func:`_trace_ray`)
whichever loop calls it, so the outer-product and the element-wise traces agree bit
for bit.

``params`` packs the relay's geometry (see :func:`pack`); it is rebuilt on every call
from the relay's attributes, so a relay changed in place (a drifted copy) traces its
own geometry.

No on-disk cache: numba's cache pickles into the package folder.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

__all__ = ["pack", "trace_grid", "trace_points"]

_JIT = {"cache": False, "nogil": True, "error_model": "numpy"}

# Offsets into ``params``.
_CENTRE = 0  # SLM centre u, v
_ROT = 2  # cos, sin of the SLM's rotation
_F1 = 4  # collimator focal length (SLM px)
_ROLL = 5  # 3 x 3, row-major: direction (row vector) @ roll
_N1 = 14  # first face's normal
_N2 = 17  # second face's normal
_OUT = 20  # 3 x 3, row-major: leaving direction (row vector) @ roll.T @ to_camera.T
_F2 = 29  # camera focal length (camera px)
_OPTICAL = 30  # optical centre x, y
_K1 = 32  # distortion k1 / radius**2
_SIZE = 33


def pack(
    slm_centre: tuple[float, float],
    rotation_deg: float,
    f1: float,
    roll: NDArray[np.float64],
    normal1: NDArray[np.float64],
    normal2: NDArray[np.float64],
    to_camera: NDArray[np.float64],
    f2: float,
    optical_centre: tuple[float, float],
    k1_per_r2: float,
) -> NDArray[np.float64]:
    """The geometry of a relay as the flat array the compiled trace reads."""
    params = np.empty(_SIZE)
    rot = np.deg2rad(rotation_deg)
    params[_CENTRE : _CENTRE + 2] = slm_centre
    params[_ROT : _ROT + 2] = np.cos(rot), np.sin(rot)
    params[_F1] = f1
    params[_ROLL : _ROLL + 9] = np.asarray(roll, dtype=np.float64).ravel()
    params[_N1 : _N1 + 3] = normal1
    params[_N2 : _N2 + 3] = normal2
    params[_OUT : _OUT + 9] = (np.asarray(roll).T @ np.asarray(to_camera).T).ravel()
    params[_F2] = f2
    params[_OPTICAL : _OPTICAL + 2] = optical_centre
    params[_K1] = k1_per_r2
    return params


@njit(inline="always", **_JIT)
def _direction(u, v, p):  # pragma: no cover - compiled
    """The collimated beam of SLM point (u, v), in the rolled prism's frame, and its
    cosine on the first face."""
    du = u - p[_CENTRE]
    dv = v - p[_CENTRE + 1]
    hu = p[_ROT] * du - p[_ROT + 1] * dv
    hv = p[_ROT + 1] * du + p[_ROT] * dv
    hz = p[_F1]
    norm = math.sqrt(hu * hu + hv * hv + hz * hz)
    hu /= norm
    hv /= norm
    hz /= norm
    r = _ROLL
    dx = hu * p[r] + hv * p[r + 3] + hz * p[r + 6]
    dy = hu * p[r + 1] + hv * p[r + 4] + hz * p[r + 7]
    dz = hu * p[r + 2] + hv * p[r + 5] + hz * p[r + 8]
    cos1 = dx * p[_N1] + dy * p[_N1 + 1] + dz * p[_N1 + 2]
    return dx, dy, dz, cos1


@njit(inline="always", **_JIT)
def _trace_ray(dx, dy, dz, cos1, n, p):  # pragma: no cover - compiled
    """Camera (x, y) of a beam through the prism of index ``n`` (NaN on total internal
    reflection): Snell's law in vector form at both faces, lens, distortion."""
    eta = 1.0 / n
    cos_t = math.sqrt(1.0 - eta * eta * (1.0 - cos1 * cos1))  # NaN if reflected
    k = cos_t - eta * cos1
    ix = eta * dx + k * p[_N1]
    iy = eta * dy + k * p[_N1 + 1]
    iz = eta * dz + k * p[_N1 + 2]
    cos2 = ix * p[_N2] + iy * p[_N2 + 1] + iz * p[_N2 + 2]
    cos_t = math.sqrt(1.0 - n * n * (1.0 - cos2 * cos2))
    k = cos_t - n * cos2
    ox = n * ix + k * p[_N2]
    oy = n * iy + k * p[_N2 + 1]
    oz = n * iz + k * p[_N2 + 2]
    o = _OUT
    cx = ox * p[o] + oy * p[o + 3] + oz * p[o + 6]
    cy = ox * p[o + 1] + oy * p[o + 4] + oz * p[o + 7]
    cz = ox * p[o + 2] + oy * p[o + 5] + oz * p[o + 8]
    xu = p[_F2] * cx / cz
    yu = p[_F2] * cy / cz
    factor = 1.0 + p[_K1] * (xu * xu + yu * yu)
    return p[_OPTICAL] + xu * factor, p[_OPTICAL + 1] + yu * factor


@njit(parallel=True, **_JIT)
def trace_grid(u, v, n, params, x, y):  # pragma: no cover - compiled
    """Trace every SLM point ``(u[i], v[i])`` at every index ``n[k]`` into ``x, y`` (P, K)."""
    for i in prange(u.size):
        dx, dy, dz, cos1 = _direction(u[i], v[i], params)
        for k in range(n.size):
            x[i, k], y[i, k] = _trace_ray(dx, dy, dz, cos1, n[k], params)


@njit(parallel=True, **_JIT)
def trace_points(u, v, n, params, x, y):  # pragma: no cover - compiled
    """Trace SLM point ``(u[i], v[i])`` at index ``n[i]`` into ``x[i], y[i]`` (1-D)."""
    for i in prange(u.size):
        dx, dy, dz, cos1 = _direction(u[i], v[i], params)
        x[i], y[i] = _trace_ray(dx, dy, dz, cos1, n[i], params)
