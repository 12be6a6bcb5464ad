"""Compiled loops of the row unmixing with mixed blurs (numba): see
:mod:`sassi_bench.spectra.row_mixture`.

Why compiled: per SLM column and bin, the coupling of every stacked pixel into every
cell within reach is a sum over the source bins whose light reaches the bin's columns
(moments of the pixel's first-pass spectrum under the spill, then Gaussian integrals at
three quadrature nodes), followed by one banded solve; as numpy that is Python calls per
system and (pixels x bins x sources) temporaries. Compiled on first use in a process
(a few seconds; no on-disk cache, as for :mod:`sassi_bench.spectra._kernels`).

How it is kept cheap (the amplitudes equal, to rounding, those of the straightforward
loops it replaced, one (pixel, bin) and one system at a time; the timings behind each
step: ``docs/notes/2026-11-29-docstring-measurements.md``):

- the nodes: a pixel's sources are weighed once, into a buffer the recurrence reads; the
  steps of the recurrence run for all of the pixel's bins in turn, so the bins' chains of
  divisions and roots overlap; one function, as calls passing the arrays cost more than
  the sums; one cosine and its sine for the three eigenvalues;
- the systems are built and solved as the separable kernel's are: each node's Gaussian
  integral at an edge two touching cells share is evaluated once, each node's 1 / sigma
  once per pixel, and the diagonally dominant systems of all bins of a column are
  eliminated together.

Not taken: the nodes from six shifted power moments in a single pass over the sources
(no faster here, and up to 1.3e-8 of the peak off where a third node is faint: the
moments cancel).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sassi_bench.maths.normal import tabulated_cdf
from sassi_bench.spectra._kernels import solve_undominated

_HALF_ROOT3 = 0.5 * math.sqrt(3.0)


@njit(nogil=True, error_model="numpy")
def blur_nodes(
    spill, sigma, y, first, stop, estimate, n, point, b, nodes
):  # pragma: no cover - compiled
    """Three-node Gauss quadrature of the row blur of pixel ``n``'s light in bin ``b``'s
    columns (:func:`mixture_nodes` of that one pixel and bin).

    The light there is sources ``k`` in ``first[b] .. stop[b]`` weighted by
    ``spill[point, b, k] * max(estimate[n, k], 0)`` (the spill alone without any
    estimate), each blurred by ``sigma[point, k]`` about ``y[n, k]``. The Gauss nodes of
    that discrete measure in sigma (exact for polynomials in sigma up to the fifth
    degree) come from its three-term recurrence (Stieltjes) and the eigenvalues of the
    3 x 3 Jacobi matrix; ``nodes = [w1, s1, w2, s2, w3, s3, centre]``, the centre being
    the weighted mean of the sources' centres; unused nodes have weight 0.
    """
    out = np.empty((1, 1, 7))
    points = np.full(1, point)
    bins = np.full(1, b)
    mixture_nodes(
        points, spill, sigma, y[n : n + 1], first, stop, bins, estimate[n : n + 1], out,
        np.empty(1),
    )  # fmt: skip
    nodes[:] = out[0, 0]


@njit(nogil=True, error_model="numpy")
def mixture_nodes(
    points, spill, sigma, y, first, stop, bins, estimate, nodes, widest
):  # pragma: no cover - compiled
    """:func:`blur_nodes` of every pixel ``n`` (at field point ``points[n]``) and bin
    ``bins[j]`` into ``nodes[n, j]``, and ``widest[j]``, the widest node of any pixel with
    weight there.

    Staged over the bins of a pixel (the sources of all its bins, then each step of the
    recurrence for all, then the nodes) so that the bins' chains of dependent divisions
    and roots overlap, which one (pixel, bin) at a time does not
    (``docs/notes/2026-12-01-measured-in-code-comments.md``); written as one function,
    since calls passing the arrays cost more than the sums themselves.
    """
    count = bins.size
    sources = 1
    for j in range(count):
        sources = max(sources, stop[bins[j]] - first[bins[j]])
    weight = np.empty((count, sources))
    width = np.empty((count, sources))
    total = np.empty(count)
    mean = np.empty(count)  # a0 of the recurrence
    a1 = np.empty(count)
    b1sq = np.empty(count)
    n1 = np.empty(count)
    n2 = np.empty(count)
    m2 = np.empty(count)
    widest[:] = 0.0
    for n in range(nodes.shape[0]):
        point = points[n]
        # Each bin's sources: weights and blurs, once; their total, mean blur and centre.
        for j in range(count):
            b = bins[j]
            lo, hi = first[b], stop[b]
            t = 0.0
            a0 = 0.0
            centre = 0.0
            for k in range(lo, hi):
                w = spill[point, b, k] * max(estimate[n, k], 0.0)
                weight[j, k - lo] = w
                width[j, k - lo] = sigma[point, k]
                t += w
                a0 += w * sigma[point, k]
                centre += w * y[n, k]
            if not t > 0.0:  # no estimate there: the spill alone
                t = 0.0
                a0 = 0.0
                centre = 0.0
                for k in range(lo, hi):
                    w = spill[point, b, k]
                    weight[j, k - lo] = w
                    t += w
                    a0 += w * sigma[point, k]
                    centre += w * y[n, k]
            total[j] = t
            mean[j] = a0 / t
            nodes[n, j, 6] = centre / t
            for q in range(3):
                nodes[n, j, 2 * q] = 0.0
                nodes[n, j, 2 * q + 1] = mean[j]
            nodes[n, j, 0] = 1.0
        # Recurrence p1 = s - a0, p2 = (s - a1) p1 - b1sq, with norms n1, n2.
        for j in range(count):
            a0 = mean[j]
            norm = 0.0
            moment = 0.0
            for i in range(stop[bins[j]] - first[bins[j]]):
                p1 = width[j, i] - a0
                norm += weight[j, i] * p1 * p1
                moment += weight[j, i] * width[j, i] * p1 * p1
            n1[j] = norm
            b1sq[j] = norm / total[j]
            a1[j] = moment / norm
        for j in range(count):
            a0 = mean[j]
            if b1sq[j] > 1e-14 * a0 * a0:
                norm = 0.0
                moment = 0.0
                for i in range(stop[bins[j]] - first[bins[j]]):
                    p1 = width[j, i] - a0
                    p2 = (width[j, i] - a1[j]) * p1 - b1sq[j]
                    norm += weight[j, i] * p2 * p2
                    moment += weight[j, i] * width[j, i] * p2 * p2
                n2[j] = norm
                m2[j] = moment
        for j in range(count):
            node = nodes[n, j]
            if b1sq[j] > 1e-14 * mean[j] * mean[j]:
                _jacobi_nodes(mean[j], a1[j], b1sq[j], n1[j], n2[j], m2[j], node)
            for q in range(3):
                if node[2 * q] > 0.0:
                    widest[j] = max(widest[j], node[2 * q + 1])


@njit(nogil=True, error_model="numpy", inline="always")
def _jacobi_nodes(a0, a1, b1sq, n1, n2, m2, nodes):  # pragma: no cover - compiled
    """The two or three Gauss nodes from the recurrence's coefficients: the eigenvalues
    of the Jacobi matrix, their weights from the orthogonal polynomials there."""
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
    # cos(phi + 2 pi q / 3), phi = acos(r) / 3, from cos(phi) and sin(phi) >= 0: one
    # cosine, not three (a large share of the nodes' time).
    cosine = math.cos(math.acos(r) / 3.0)
    sine = math.sqrt(max(1.0 - cosine * cosine, 0.0))
    inverse_b1 = 1.0 / b1
    inverse_b2 = 1.0 / b2
    for q in range(3):
        turned = cosine
        if q == 1:
            turned = -0.5 * cosine - _HALF_ROOT3 * sine
        elif q == 2:
            turned = -0.5 * cosine + _HALF_ROOT3 * sine
        node = mean + 2.0 * scale * turned
        p1 = (node - a0) * inverse_b1
        p2 = ((node - a1) * p1 - b1) * inverse_b2
        nodes[2 * q] = 1.0 / (1.0 + p1 * p1 + p2 * p2)
        nodes[2 * q + 1] = node


@njit(nogil=True, error_model="numpy")
def unmix_mixed(sums, lo, hi, index, bins, reach, nodes, table, out):  # pragma: no cover - compiled
    """Amplitudes of stacked pixels in bins ``bins`` with each pixel's mixed row blur.

    Per SLM column (``index``: (G, S) pixels top to bottom, -1 pads) and bin
    ``b = bins[j]``, the banded system ``A[s, s + d]`` (``|d| <= reach[j]``) is the light
    of pixel ``s + d`` in cell ``s`` under its blur ``nodes[n, j]`` (:func:`blur_nodes`);
    ``out[:, b]`` is overwritten for those bins only.

    As :func:`sassi_bench.spectra._kernels.unmix_rows` does for one blur a bin: the
    systems of all bins of a column are built and solved together, bins innermost, each
    distance ``d`` only for the bins that reach it; a cell's upper edge is the
    previous cell's lower edge where they touch, so each node's Gaussian integral there is
    evaluated once for both; diagonally dominant systems are eliminated without pivoting,
    all bins at once, any other alone with partial pivoting.
    """
    groups, stack = index.shape
    count = bins.size
    w = 0
    for j in range(count):
        w = max(w, reach[j])
    band = np.zeros((stack, 2 * w + 1, count))  # band[s, d + w, j] = A_j[s, s + d]
    x = np.empty((stack, count))
    previous = np.zeros((2 * w + 1, count, 3))  # node CDFs at the previous cell's lower edge
    current = np.zeros((2 * w + 1, count, 3))
    rest = np.empty(count)
    dominant = np.empty(count, dtype=np.bool_)
    factor = np.empty(count)
    alone = np.empty((stack, 3 * w + 1))
    alone_x = np.empty(stack)
    inverse = np.empty((stack, count, 3))
    for g in range(groups):
        size = 0
        while size < stack and index[g, size] >= 0:
            size += 1
        # Entries are written only where a bin reaches; near the end of the stack, entries
        # beyond it may still hold those of a longer stack.
        band[max(0, size - w) : size] = 0.0
        for s in range(size):  # each node's 1 / sigma, once per pixel
            m = index[g, s]
            for j in range(count):
                for q in range(3):
                    if nodes[m, j, 2 * q] != 0.0:
                        inverse[s, j, q] = 1.0 / nodes[m, j, 2 * q + 1]
        for s in range(size):
            n = index[g, s]
            up = index[g, s - 1] if s > 0 else -1
            for d in range(-min(w, s), min(w, size - 1 - s) + 1):
                m = index[g, s + d]
                k = abs(d)
                for j in range(count):
                    if reach[j] < k:
                        continue
                    b = bins[j]
                    top, bottom = lo[n, b], hi[n, b]
                    # Pixel m at this cell's upper edge: the previous cell's lower edge.
                    shared = up >= 0 and d < reach[j] and top == hi[up, b]
                    centre = nodes[m, j, 6]
                    value = 0.0
                    for q in range(3):
                        weight = nodes[m, j, 2 * q]
                        if weight != 0.0:
                            scale = inverse[s + d, j, q]
                            lower = tabulated_cdf((bottom - centre) * scale, table)
                            if shared:
                                upper = previous[d + 1 + w, j, q]
                            else:
                                upper = tabulated_cdf((top - centre) * scale, table)
                            current[d + w, j, q] = lower
                            value += weight * (lower - upper)
                    band[s, d + w, j] = value
            previous, current = current, previous
            for j in range(count):
                x[s, j] = sums[n, bins[j]]
        cells = index[g]
        solve_undominated(band, x, size, reach, cells, bins, dominant, rest, alone, alone_x, out)
        # Elimination without pivoting of all bins' systems at once (the results of
        # systems that are not dominant are discarded), as in the separable kernel.
        for k in range(size):
            last = min(w, size - 1 - k)
            for dr in range(1, last + 1):
                r = k + dr
                for j in range(count):
                    if reach[j] < dr:
                        continue
                    factor[j] = band[r, w - dr, j] / band[k, w, j]
                    x[r, j] -= factor[j] * x[k, j]
                for dj in range(1, last + 1):
                    level = max(dr, dj)
                    for j in range(count):
                        if reach[j] < level:
                            continue
                        band[r, dj - dr + w, j] -= factor[j] * band[k, dj + w, j]
        for i in range(size - 1, -1, -1):
            for dj in range(1, min(w, size - 1 - i) + 1):
                for j in range(count):
                    if reach[j] < dj:
                        continue
                    x[i, j] -= band[i, dj + w, j] * x[i + dj, j]
            for j in range(count):
                x[i, j] /= band[i, w, j]
        for s in range(size):
            n = cells[s]
            for j in range(count):
                if dominant[j]:
                    out[n, bins[j]] = x[s, j]
