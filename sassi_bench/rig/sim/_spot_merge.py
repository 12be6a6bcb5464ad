"""Merging a pixel's neighbouring wavelength samples into one spot of the same moments.

A design rig's sparse frame deposits one correlated Gaussian per (open pixel, wavelength
sample) (:mod:`~sassi_bench.rig.sim._gauss_splat`). Neighbouring samples of a pixel land
a fraction of a pixel apart, under spots a pixel or more wide, so most of them draw
nearly the same shape. A run of samples whose centres span at most :data:`SPAN_SIGMAS`
of the narrowest member's sigma (the spot's minor axis with the camera pixel's box) is
drawn as one Gaussian carrying the run's total weight, weighted mean centre and weighted
covariance plus the centres' own spread: the sum of the run's spots and the merged spot
have the same energy, centroid and second moments, and differ only in their fourth and
higher moments. The frame so drawn stays within 1e-3 of its peak of the sample-by-sample
frame (``tests/rig/sim/test_spot_merge.py`` holds both design rigs' pinhole frames to
it), for a third to a half of the spots.

The parametric bench has no such step: its spots are separable and drawn two samples in
one pass (:mod:`~sassi_bench.rig.sim._splat`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ["SPAN_SIGMAS", "merge_neighbouring_spots"]

#: The widest span of a merged run's centres, in sigmas of its narrowest member.
SPAN_SIGMAS = 0.75


@njit(cache=False, error_model="numpy")
def _merge(x, y, cxx, cyy, cxy, weights, span):  # pragma: no cover - compiled
    pixels, samples = x.shape
    size = pixels * samples
    out = np.empty((6, size))
    span2 = span * span
    merged = 0
    for p in range(pixels):
        first = 0
        while first < samples:
            # grow the run [first, end) while its centres span at most `span` narrowest sigmas
            narrowest = math.inf
            end = first
            while end < samples:
                half = 0.5 * (cxx[p, end] - cyy[p, end])
                minor = 0.5 * (cxx[p, end] + cyy[p, end]) - math.sqrt(half**2 + cxy[p, end] ** 2)
                variance = min(narrowest, minor + 1.0 / 12.0)
                dx = x[p, end] - x[p, first]
                dy = y[p, end] - y[p, first]
                if end > first and dx * dx + dy * dy > span2 * variance:
                    break
                narrowest = variance
                end += 1
            total = 0.0
            mx = 0.0
            my = 0.0
            for k in range(first, end):
                total += weights[p, k]
                mx += weights[p, k] * x[p, k]
                my += weights[p, k] * y[p, k]
            if total > 0.0:
                mx /= total
                my /= total
                sxx = 0.0
                syy = 0.0
                sxy = 0.0
                for k in range(first, end):
                    dx = x[p, k] - mx
                    dy = y[p, k] - my
                    sxx += weights[p, k] * (cxx[p, k] + dx * dx)
                    syy += weights[p, k] * (cyy[p, k] + dy * dy)
                    sxy += weights[p, k] * (cxy[p, k] + dx * dy)
                out[0, merged] = mx
                out[1, merged] = my
                out[2, merged] = sxx / total
                out[3, merged] = syy / total
                out[4, merged] = sxy / total
                out[5, merged] = total
                merged += 1
            first = end
    return out[:, :merged]


def merge_neighbouring_spots(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    cxx: NDArray[np.float64],
    cyy: NDArray[np.float64],
    cxy: NDArray[np.float64],
    weights: NDArray[np.float64],
    span_sigmas: float = SPAN_SIGMAS,
) -> tuple[NDArray[np.float64], ...]:
    """Merge runs of each pixel's neighbouring samples (P, K) into spots of the same
    moments: ``(x, y, cxx, cyy, cxy, weights)``, each (1, N), N <= P K, in (pixel, sample)
    order; spots of no weight are dropped.

    Parameters
    ----------
    x, y
        Spot centres, camera px (P pixels, K samples in wavelength order).
    cxx, cyy, cxy
        Spot covariances, camera px**2 (without the camera pixel's box).
    weights
        Each spot's energy (>= 0).
    span_sigmas
        The widest span of a run's centres, in sigmas of its narrowest member.

    Examples
    --------
    >>> x = np.array([[10.0, 10.2, 14.0]])
    >>> one = np.ones_like(x)
    >>> spots = merge_neighbouring_spots(x, 5 * one, one, one, 0 * one, one)
    >>> spots[0].round(2).tolist(), spots[2].round(2).tolist(), spots[5].tolist()
    ([[10.1, 14.0]], [[1.01, 1.0]], [[2.0, 1.0]])
    """
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (x, y, cxx, cyy, cxy, weights)]
    merged = _merge(*arrays, float(span_sigmas))
    return tuple(np.ascontiguousarray(row)[None, :] for row in merged)
