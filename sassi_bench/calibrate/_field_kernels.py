"""Compiled loop of the field fits (numba): a 2-D Legendre polynomial at many points.

Why compiled: a laser map is evaluated at every decoded pixel (two million at the
prototype's scale) to grade its fit. Through the design matrix that is a 340 MB array,
and numpy's product of an (N, 6) by a (6, 6) matrix is slow for tall, thin operands;
point by point, with the three-term recurrence, it takes a fraction of the CPU
(``docs/notes/2026-12-01-measured-in-code-comments.md``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(nogil=True)
def legendre_field(u, v, table, out):  # pragma: no cover - compiled
    """``out[n] = sum_ij table[i, j] P_i(u[n]) P_j(v[n])`` for Legendre polynomials ``P``."""
    size = table.shape[0]
    pu = np.empty(size)
    pv = np.empty(size)
    for n in range(u.size):
        x, y = u[n], v[n]
        pu[0] = 1.0
        pv[0] = 1.0
        if size > 1:
            pu[1] = x
            pv[1] = y
        for k in range(2, size):  # k P_k = (2k - 1) x P_{k-1} - (k - 1) P_{k-2}
            pu[k] = ((2 * k - 1) * x * pu[k - 1] - (k - 1) * pu[k - 2]) / k
            pv[k] = ((2 * k - 1) * y * pv[k - 1] - (k - 1) * pv[k - 2]) / k
        total = 0.0
        for i in range(size):
            row = 0.0
            for j in range(size - i):
                row += table[i, j] * pv[j]
            total += pu[i] * row
        out[n] = total
