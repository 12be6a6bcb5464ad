"""The compiled loop (numba) that splats correlated Gaussian spots, pixel-integrated.

A design rig's spot changes size, shape and orientation with the SLM point and the
wavelength, so the separable tabulated profiles of :mod:`~sassi_bench.rig.sim._splat`
(one per wavelength) do not apply. Each (open pixel, wavelength sample) here deposits a
Gaussian of its own covariance (cxx, cyy, cxy), integrated over every camera pixel:
exactly along y (the row's share is a difference of normal CDFs), and along x from the
distribution of x given that y falls in the row: a Gaussian centred at
``x + (cxy / cyy) (E[y | row] - y)`` of variance ``cxx - cxy**2 / cyy`` plus
``(cxy / cyy)**2 Var[y | row]`` (y in a row is a truncated normal), again a CDF difference.
That keeps the spot's cross moment exact; the row's x profile is Gaussian where it is
really a mixture, which changes the second moments by far less than 1 %.
Spots are cut at 4 sigma.

The frame is cut into horizontal bands, one task each, and each band visits the spots in
order, so the frame is the same bit for bit whatever the number of threads.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

__all__ = ["BANDS", "splat_gaussians"]

#: Horizontal bands of the frame, one task each.
BANDS = 32
_TRUNCATE = 4.0
_SQRT1_2 = 1.0 / math.sqrt(2.0)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


# The normal CDF tabulated every 1/256 sigma over +-8.5 sigma and interpolated linearly
# (error < 5e-7): a spot is a few hundred CDF values, and the table reads them several
# times faster than math.erf.
_CDF_STEP = 1.0 / 256.0
_CDF_REACH = 8.5
_CDF_TABLE = np.array(
    [
        0.5 * (1.0 + math.erf(z * _SQRT1_2))
        for z in np.arange(-_CDF_REACH, _CDF_REACH + _CDF_STEP, _CDF_STEP)
    ]
)


@njit(inline="always")
def _cdf(t):  # pragma: no cover - compiled
    s = (t + _CDF_REACH) / _CDF_STEP
    if s <= 0.0:
        return 0.0
    if s >= _CDF_TABLE.size - 1:
        return 1.0
    i = int(s)
    f = s - i
    return _CDF_TABLE[i] + f * (_CDF_TABLE[i + 1] - _CDF_TABLE[i])


@njit(inline="always")
def _pdf(t):  # pragma: no cover - compiled
    return math.exp(-0.5 * t * t) * _INV_SQRT_2PI


@njit(parallel=True, error_model="numpy", cache=False)
def splat_gaussians(x, y, cxx, cyy, cxy, weights, out):  # pragma: no cover - compiled
    """Add Gaussian spots (P, K) at centres ``x, y`` with covariances ``cxx, cyy, cxy``
    (camera px, px**2) and energies ``weights`` into ``out`` (H, W, float32), in place."""
    height, width = out.shape
    n_pix, n_lam = x.shape
    rows_per_band = (height + BANDS - 1) // BANDS
    for band in prange(BANDS):
        first = band * rows_per_band
        last = min(height, first + rows_per_band) - 1
        for p in range(n_pix):
            for k in range(n_lam):
                w = weights[p, k]
                if w == 0.0:
                    continue
                vy = cyy[p, k]
                sy = math.sqrt(vy)
                ry = math.ceil(_TRUNCATE * sy) + 1
                cy = round(y[p, k])
                top = max(cy - ry, first)
                bottom = min(cy + ry, last)
                if top > bottom:
                    continue
                beta = cxy[p, k] / vy
                vx = max(cxx[p, k] - cxy[p, k] * beta, 1e-6)
                # reach: the widest a row's x spread can be (vx plus a row's share of y)
                rx = math.ceil(_TRUNCATE * math.sqrt(vx + beta * beta / 12.0)) + 1
                for i in range(top, bottom + 1):
                    lo = (i - 0.5 - y[p, k]) / sy
                    hi = (i + 0.5 - y[p, k]) / sy
                    share = _cdf(hi) - _cdf(lo)
                    if share <= 1e-12:
                        continue
                    # y within the row: a truncated normal, whose mean and variance carry
                    # into x through the correlation
                    d_lo, d_hi = _pdf(lo), _pdf(hi)
                    shift = (d_lo - d_hi) / share
                    spread = 1.0 + (lo * d_lo - hi * d_hi) / share - shift * shift
                    mx = x[p, k] + beta * sy * shift
                    sx = math.sqrt(vx + beta * beta * vy * max(spread, 0.0))
                    cx = round(mx)
                    left = max(cx - rx, 0)
                    right = min(cx + rx, width - 1)
                    a = w * share
                    lower = _cdf((left - 0.5 - mx) / sx)
                    for j in range(left, right + 1):
                        upper = _cdf((j + 0.5 - mx) / sx)
                        out[i, j] += np.float32(a * (upper - lower))
                        lower = upper
