"""Banded linear solvers, compiled: LU with partial pivoting and a skyline Cholesky.

The systems the reductions solve are small and many (a frame's stacked pixels per SLM
column and bin, a background spline's collocation per axis, a camera column's units under
a dense mask), and they are solved inside compiled loops, where a call into LAPACK cannot
be made; so the two factorisations are written once here, for every solver to share:

* :func:`band_lu` / :func:`band_lu_solve`: LU with partial pivoting of a square banded
  matrix (as LAPACK's ``gbtrf``/``gbtrs``), in a storage of ``3 p + 1`` columns for
  bandwidth ``p``: ``a[i, j - i + p] = A[i, j]`` for ``|j - i| <= p``, the columns beyond
  ``2 p`` holding the fill-in of row exchanges, the multipliers kept where the eliminated
  entries were; :func:`band_solve` factors and solves one right-hand side in one pass;
* :func:`skyline_cholesky` / :func:`skyline_solve`: the Cholesky factor of a symmetric
  positive (semi-)definite matrix of variable bandwidth, row ``i`` stored from its first
  non-zero column ``envelope[i]`` to its diagonal (which holds the *reciprocal* of the
  factor's diagonal); a fixed band is the envelope ``max(0, i - p)``. A non-positive
  pivot (an unknown nothing constrains, numerically) gets an identity row: the unknown
  takes its right-hand side, zero for an unknown without data.

Back substitution multiplies by the diagonal's reciprocal, a column at a time, as the
background spline's solver did before it was shared (the results of that spline are so
unchanged to the bit). Tested against ``scipy.linalg.solve_banded`` and
``solveh_banded`` (``tests/maths/test_banded.py``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

__all__ = ["band_lu", "band_lu_solve", "band_solve", "skyline_cholesky", "skyline_solve"]

_JIT = {"cache": False, "nogil": True, "error_model": "numpy"}
#: The skyline's inner products may be reassociated (so they are vectorised): their last
#: bits then follow the machine's vector width.
_SUMS = dict(_JIT, fastmath={"reassoc", "contract"})
#: An unsigned index: numba skips the negative-index wraparound on it.
_U = np.uint64


@njit(**_JIT)
def band_lu(a, size, p, pivots):  # pragma: no cover - compiled
    """LU factors of the first ``size`` rows of a banded matrix, in place, with partial
    pivoting: ``a`` (``size`` x ``3 p + 1``, the fill-in columns zero on entry) holds U and
    the multipliers, ``pivots[k]`` the row exchanged with row ``k``.

    Examples
    --------
    >>> a = np.array([[0.0, 2.0, 1.0, 0.0], [1.0, 3.0, 0.0, 0.0]])  # [[2, 1], [1, 3]]
    >>> pivots = np.zeros(2, np.intp)
    >>> band_lu(a, 2, 1, pivots)
    >>> x = np.array([[3.0], [4.0]])
    >>> band_lu_solve(a, 2, 1, pivots, x)
    >>> x.ravel().tolist()
    [1.0, 1.0]
    """
    for k in range(size):
        pivot_row = k
        best = abs(a[k, p])
        for r in range(k + 1, min(k + p, size - 1) + 1):
            if abs(a[r, k - r + p]) > best:
                best = abs(a[r, k - r + p])
                pivot_row = r
        pivots[k] = pivot_row
        end = min(k + 2 * p, size - 1)
        if pivot_row != k:
            for j in range(k, end + 1):
                tmp = a[k, j - k + p]
                a[k, j - k + p] = a[pivot_row, j - pivot_row + p]
                a[pivot_row, j - pivot_row + p] = tmp
        pivot = a[k, p]
        for r in range(k + 1, min(k + p, size - 1) + 1):
            factor = a[r, k - r + p] / pivot
            if factor != 0.0:
                for j in range(k + 1, end + 1):
                    a[r, j - r + p] -= factor * a[k, j - k + p]
            a[r, k - r + p] = factor


@njit(**_JIT)
def band_lu_solve(a, size, p, pivots, x):  # pragma: no cover - compiled
    """Solve ``A X = x`` in place (``x``: ``size`` x m right-hand sides) with the factors of
    :func:`band_lu`."""
    columns = x.shape[1]
    for k in range(size):
        pivot_row = pivots[k]
        if pivot_row != k:
            for c in range(columns):
                tmp = x[k, c]
                x[k, c] = x[pivot_row, c]
                x[pivot_row, c] = tmp
        for r in range(k + 1, min(k + p, size - 1) + 1):
            factor = a[r, k - r + p]
            if factor != 0.0:
                for c in range(columns):
                    x[r, c] -= factor * x[k, c]
    for k in range(size - 1, -1, -1):
        d = 1.0 / a[k, p]
        for c in range(columns):
            x[k, c] *= d
        for i in range(max(0, k - 2 * p), k):
            u = a[i, k - i + p]
            if u != 0.0:
                for c in range(columns):
                    x[i, c] -= u * x[k, c]


@njit(**_JIT)
def band_solve(a, x, size, p):  # pragma: no cover - compiled
    """Solve one banded system ``A x = x`` in place by :func:`band_lu` and
    :func:`band_lu_solve` (``a`` as there; ``x`` a vector of at least ``size``)."""
    pivots = np.empty(size, np.intp)
    band_lu(a, size, p, pivots)
    band_lu_solve(a, size, p, pivots, x[:size].reshape(size, 1))


@njit(**_SUMS)
def skyline_cholesky(envelope, start, values, first, stop):  # pragma: no cover - compiled
    """The Cholesky factor ``L`` of rows ``first`` to ``stop - 1`` of a skyline matrix, in place.

    Row ``i`` holds ``A[i, envelope[i] .. i]`` at ``values[start[i] ..]`` on entry and
    ``L[i, envelope[i] .. i]`` on return, with ``1 / L[i, i]`` on the diagonal. A row
    couples only with rows of the same range (``envelope[i] >= first``). A non-positive
    pivot gets an identity row (zeroed, its diagonal one): its unknown takes its
    right-hand side.

    Inner loops index with unsigned offsets (:data:`_U`): numba checks a signed index for
    a negative value at every access, which stops the loops from being vectorised.
    """
    for i in range(first, stop):
        ei = envelope[i]
        fi = start[i]
        for j in range(ei, i + 1):
            g = values[fi + j - ei]
            ej = envelope[j]
            fj = start[j]
            k0 = max(ei, ej)
            if j > k0:
                pa = _U(fi + k0 - ei)
                pb = _U(fj + k0 - ej)
                for q in range(_U(j - k0)):
                    g -= values[pa + q] * values[pb + q]
            if j < i:
                values[fi + j - ei] = g * values[fj + j - ej]
            elif g > 0.0:
                values[fi + i - ei] = 1.0 / math.sqrt(g)
            else:
                for k in range(ei, i):
                    values[fi + k - ei] = 0.0
                values[fi + i - ei] = 1.0


@njit(**_SUMS)
def skyline_solve(envelope, start, factor, x, first, stop):  # pragma: no cover - compiled
    """Solve ``L Lᵀ y = x`` in place for rows ``first`` to ``stop - 1`` with the factor of
    :func:`skyline_cholesky`."""
    # Forward: L z = x (rows stored left to right, 1 / diagonal last).
    for i in range(first, stop):
        ei = envelope[i]
        fi = _U(start[i])
        acc = x[i]
        for q in range(_U(i - ei)):
            acc -= factor[fi + q] * x[ei + q]
        x[i] = acc * factor[fi + i - ei]
    # Backward: Lᵀ y = z, a row of L at a time.
    for i in range(stop - 1, first - 1, -1):
        ei = envelope[i]
        fi = _U(start[i])
        y = x[i] * factor[fi + i - ei]
        x[i] = y
        for q in range(_U(i - ei)):
            x[ei + q] -= factor[fi + q] * y
