"""Compiled loop of the row unmixing with mixed blurs (numba): see
:mod:`sassi_bench.spectra.row_mixture`.

Why compiled: per SLM column and bin, the coupling of every stacked pixel into every
cell within reach is a sum over the source bins whose light reaches the bin's columns
(moments of the pixel's first-pass spectrum under the spill, then Gaussian integrals at
three quadrature nodes), followed by one banded solve; as numpy that is Python calls per
system and (pixels x bins x sources) temporaries. Compiled on first use in a process.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sassi_bench.spectra._kernels import _solve_band, normal_cdf


@njit(nogil=True, error_model="numpy")
def _weight(spill, estimate, point, b, n, k, use_spill):  # pragma: no cover - compiled
    """Weight of source ``k`` in pixel ``n``'s light in bin ``b``'s columns."""
    if use_spill:
        return spill[point, b, k]
    return spill[point, b, k] * max(estimate[n, k], 0.0)


@njit(nogil=True, error_model="numpy")
def blur_nodes(
    spill, sigma, y, first, stop, estimate, n, point, b, nodes
):  # pragma: no cover - compiled
    """Three-node Gauss quadrature of the row blur of pixel ``n``'s light in bin ``b``'s
    columns.

    The light there is sources ``k`` in ``first[b] .. stop[b]`` weighted by
    ``spill[point, b, k] * max(estimate[n, k], 0)`` (the spill alone without any
    estimate), each blurred by ``sigma[point, k]`` about ``y[n, k]``. The Gauss nodes of
    that discrete measure in sigma (exact for polynomials in sigma up to the fifth
    degree) come from its three-term recurrence (Stieltjes) and the eigenvalues of the
    3 x 3 Jacobi matrix; ``nodes = [w1, s1, w2, s2, w3, s3, centre]``, the centre being
    the weighted mean of the sources' centres; unused nodes have weight 0.
    """
    lo, hi = first[b], stop[b]
    total = 0.0
    for k in range(lo, hi):
        total += spill[point, b, k] * max(estimate[n, k], 0.0)
    use_spill = not total > 0.0
    total = 0.0
    a0 = 0.0
    centre = 0.0
    for k in range(lo, hi):
        weight = _weight(spill, estimate, point, b, n, k, use_spill)
        total += weight
        a0 += weight * sigma[point, k]
        centre += weight * y[n, k]
    a0 /= total
    nodes[6] = centre / total
    for q in range(3):
        nodes[2 * q] = 0.0
        nodes[2 * q + 1] = a0
    nodes[0] = 1.0
    # Recurrence p1 = s - a0, p2 = (s - a1) p1 - b1sq, with norms n1, n2.
    n1 = 0.0
    m1 = 0.0
    for k in range(lo, hi):
        weight = _weight(spill, estimate, point, b, n, k, use_spill)
        p1 = sigma[point, k] - a0
        n1 += weight * p1 * p1
        m1 += weight * sigma[point, k] * p1 * p1
    b1sq = n1 / total
    if b1sq <= 1e-14 * a0 * a0:
        return
    a1 = m1 / n1
    n2 = 0.0
    m2 = 0.0
    for k in range(lo, hi):
        weight = _weight(spill, estimate, point, b, n, k, use_spill)
        p1 = sigma[point, k] - a0
        p2 = (sigma[point, k] - a1) * p1 - b1sq
        n2 += weight * p2 * p2
        m2 += weight * sigma[point, k] * p2 * p2
    b1 = math.sqrt(b1sq)
    if n2 <= 1e-14 * n1 * a0 * a0:  # two distinct blurs: the 2 x 2 Jacobi matrix
        half = 0.5 * (a0 - a1)
        root = math.sqrt(half * half + b1sq)
        for q in range(2):
            node = 0.5 * (a0 + a1) + (root if q else -root)
            p1 = (node - a0) / b1
            nodes[2 * q] = 1.0 / (1.0 + p1 * p1)
            nodes[2 * q + 1] = node
        return
    a2 = m2 / n2
    b2sq = n2 / n1
    b2 = math.sqrt(b2sq)
    # Eigenvalues of the symmetric tridiagonal [[a0, b1, 0], [b1, a1, b2], [0, b2, a2]].
    mean = (a0 + a1 + a2) / 3.0
    d0, d1, d2 = a0 - mean, a1 - mean, a2 - mean
    scale = math.sqrt((d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (b1sq + b2sq)) / 6.0)
    det = d0 * (d1 * d2 - b2sq) - b1sq * d2
    r = min(max(0.5 * det / (scale * scale * scale), -1.0), 1.0)
    phi = math.acos(r) / 3.0
    for q in range(3):
        node = mean + 2.0 * scale * math.cos(phi + 2.0 * math.pi * q / 3.0)
        p1 = (node - a0) / b1
        p2 = ((node - a1) * p1 - b1) / b2
        nodes[2 * q] = 1.0 / (1.0 + p1 * p1 + p2 * p2)
        nodes[2 * q + 1] = node


@njit(nogil=True, error_model="numpy")
def mixture_nodes(
    points, spill, sigma, y, first, stop, bins, estimate, nodes
):  # pragma: no cover - compiled
    """:func:`blur_nodes` of every pixel ``n`` and bin ``bins[j]`` into ``nodes[n, j]``."""
    for n in range(nodes.shape[0]):
        for j in range(bins.size):
            blur_nodes(spill, sigma, y, first, stop, estimate, n, points[n], bins[j], nodes[n, j])


@njit(nogil=True, error_model="numpy")
def unmix_mixed(sums, lo, hi, index, bins, reach, nodes, table, out):  # pragma: no cover - compiled
    """Amplitudes of stacked pixels in bins ``bins`` with each pixel's mixed row blur.

    Per SLM column (``index``: (G, S) pixels top to bottom, -1 pads) and bin
    ``b = bins[j]``, the banded system ``A[s, s + d]`` (``|d| <= reach[j]``) is the light
    of pixel ``s + d`` in cell ``s`` under its blur ``nodes[n, j]`` (:func:`blur_nodes`),
    solved by banded LU with partial pivoting; ``out[:, b]`` is overwritten for those
    bins only.
    """
    groups, stack = index.shape
    widest = 0
    for j in range(bins.size):
        widest = max(widest, reach[j])
    band = np.zeros((stack, 3 * widest + 1))
    x = np.empty(stack)
    for g in range(groups):
        size = 0
        while size < stack and index[g, size] >= 0:
            size += 1
        for j in range(bins.size):
            b = bins[j]
            p = reach[j]
            band[:size, : 3 * p + 1] = 0.0
            for s in range(size):
                n = index[g, s]
                for d in range(-min(p, s), min(p, size - 1 - s) + 1):
                    node = nodes[index[g, s + d], j]
                    value = 0.0
                    for q in range(3):
                        if node[2 * q] != 0.0:
                            scale = 1.0 / node[2 * q + 1]
                            value += node[2 * q] * (
                                normal_cdf((hi[n, b] - node[6]) * scale, table)
                                - normal_cdf((lo[n, b] - node[6]) * scale, table)
                            )
                    band[s, d + p] = value
                x[s] = sums[n, b]
            _solve_band(band, x, size, p)
            for s in range(size):
                out[index[g, s], b] = x[s]
