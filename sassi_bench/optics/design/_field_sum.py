"""The compiled loop (numba) that sums a few weighted coefficient rows per point.

A point's value on the field is 16 weighted rows of the wavelength-contracted
coefficients (a cubic B-spline's 4 x 4 non-zero weights). As a sparse matrix product
(``scipy.sparse``) each multiply-add is a scalar step of a generic loop; here each of the
16 rows is one contiguous vector multiply-add, which is faster on the renderer's blocks
(docs/notes/2026-11-29-design-render-speed.md, fourth pass).

No on-disk cache: numba's cache pickles into the package folder.
"""

from __future__ import annotations

from numba import njit

__all__ = ["weighted_rows"]


@njit(cache=False, nogil=True, error_model="numpy")
def weighted_rows(weights, columns, coefficients, out):  # pragma: no cover - compiled
    """``out[p] = sum_k weights[p, k] * coefficients[columns[p, k]]``, in place.

    Parameters
    ----------
    weights, columns
        (P, J) weights and the coefficient rows they take.
    coefficients
        (F, C) rows.
    out
        (P, C), zeroed by the caller.
    """
    for p in range(out.shape[0]):
        row = out[p]
        for k in range(weights.shape[1]):
            w = weights[p, k]
            taken = coefficients[columns[p, k]]
            for j in range(row.size):
                row[j] += w * taken[j]
