"""The interpolants' compiled row sum: each point's weighted coefficient rows, summed."""

import numpy as np
from scipy.sparse import csr_array

from sassi_bench.optics.design._field_sum import weighted_rows


def test_the_row_sum_is_the_sparse_product():
    rng = np.random.default_rng(3)
    points, taken, rows, columns = 40, 16, 300, 57
    weights = rng.normal(size=(points, taken))
    chosen = rng.integers(0, rows, size=(points, taken))
    coefficients = rng.normal(size=(rows, columns))
    out = np.zeros((points, columns))
    weighted_rows(weights, chosen, coefficients, out)
    pointers = np.arange(0, points * taken + 1, taken)
    basis = csr_array((weights.ravel(), chosen.ravel(), pointers), shape=(points, rows))
    np.testing.assert_allclose(out, basis @ coefficients, rtol=1e-12, atol=1e-12)
