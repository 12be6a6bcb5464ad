"""The banded solvers against scipy's: LU with partial pivoting against
``scipy.linalg.solve_banded``, the skyline Cholesky against ``solveh_banded``."""

import numpy as np
import pytest
from scipy.linalg import solve_banded, solveh_banded

from sassi_bench.maths.banded import (
    band_lu,
    band_lu_solve,
    band_solve,
    skyline_cholesky,
    skyline_solve,
)


def _random_band(rng, size, p, diagonal):
    """A banded matrix in the solvers' storage (zero fill-in columns) and in scipy's."""
    band = np.zeros((size, 3 * p + 1))
    scipy_form = np.zeros((2 * p + 1, size))
    for d in range(-p, p + 1):
        i = np.arange(max(0, -d), min(size, size - d))
        values = rng.uniform(-1.0, 1.0, i.size) + (diagonal if d == 0 else 0.0)
        band[i, d + p] = values
        scipy_form[p - d, i + d] = values  # ab[u + i - j, j] = A[i, j]
    return band, scipy_form


@pytest.mark.parametrize("p", [0, 1, 3])
@pytest.mark.parametrize("diagonal", [4.0, 0.0], ids=["dominant", "needs-pivoting"])
def test_band_lu_matches_solve_banded(p, diagonal):
    rng = np.random.default_rng(p)
    size = 40
    band, ab = _random_band(rng, size, p, diagonal)
    rhs = rng.normal(size=(size, 3))
    expected = solve_banded((p, p), ab, rhs)
    pivots = np.empty(size, np.intp)
    factors = band.copy()
    band_lu(factors, size, p, pivots)
    x = rhs.copy()
    band_lu_solve(factors, size, p, pivots, x)
    np.testing.assert_allclose(x, expected, rtol=1e-9, atol=1e-9)
    one = rhs[:, 0].copy()
    band_solve(band.copy(), one, size, p)
    np.testing.assert_allclose(one, expected[:, 0], rtol=1e-9, atol=1e-9)
    if diagonal == 0.0 and p > 0:
        assert np.any(pivots != np.arange(size))  # the case needed row exchanges


def _skyline(dense):
    """A symmetric matrix's skyline storage: each row from its first non-zero column."""
    size = dense.shape[0]
    envelope = np.array([np.flatnonzero(dense[i, : i + 1])[0] for i in range(size)])
    start = np.concatenate([[0], np.cumsum(np.arange(size) - envelope + 1)])[:-1]
    values = np.concatenate([dense[i, envelope[i] : i + 1] for i in range(size)])
    return envelope.astype(np.int64), start.astype(np.int64), values


@pytest.mark.parametrize("p", [1, 2, 5])
def test_skyline_cholesky_matches_solveh_banded(p):
    rng = np.random.default_rng(10 + p)
    size = 30
    # A symmetric positive definite band of varying width (a skyline inside the band).
    dense = np.zeros((size, size))
    for i in range(size):
        width = rng.integers(0, p + 1)
        for j in range(max(0, i - width), i):
            dense[i, j] = dense[j, i] = rng.uniform(-1.0, 1.0)
    dense += np.diag(np.abs(dense).sum(axis=1) + 1.0)
    rhs = rng.normal(size=size)
    ab = np.zeros((p + 1, size))  # upper form: ab[p + i - j, j] = A[i, j]
    for d in range(p + 1):
        ab[p - d, d:] = np.diag(dense, d)
    expected = solveh_banded(ab, rhs)
    envelope, start, values = _skyline(dense)
    skyline_cholesky(envelope, start, values, 0, size)
    x = rhs.copy()
    skyline_solve(envelope, start, values, x, 0, size)
    np.testing.assert_allclose(x, expected, rtol=1e-10, atol=1e-12)


def test_a_skyline_unknown_nothing_constrains_takes_its_right_hand_side():
    dense = np.array([[2.0, 0.0, 1.0], [0.0, 0.0, 0.0], [1.0, 0.0, 3.0]])
    envelope, start, values = (
        np.array([0, 1, 0]),
        np.array([0, 1, 2]),
        np.array([2.0, 0.0, 1.0, 0.0, 3.0]),
    )
    skyline_cholesky(envelope, start, values, 0, 3)
    x = np.array([3.0, 0.0, 4.0])  # no data on the second unknown
    skyline_solve(envelope, start, values, x, 0, 3)
    kept = [0, 2]
    np.testing.assert_allclose(x[kept], np.linalg.solve(dense[np.ix_(kept, kept)], [3.0, 4.0]))
    assert x[1] == 0.0
