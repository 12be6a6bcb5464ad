import numpy as np
import pytest

from sassi_bench.maths.order_statistics import median, select


@pytest.mark.parametrize("n", [1, 2, 3, 10, 1000])
def test_select_places_the_rank_th_value_and_leaves_the_tail(n):
    rng = np.random.default_rng(n)
    for trial in range(20):
        values = rng.integers(0, 5, n + 3).astype(float) if trial % 2 else rng.random(n + 3)
        rank = int(rng.integers(0, n))
        work = values.copy()
        got = select(work, n, rank)
        assert got == np.sort(values[:n])[rank]
        assert np.all(work[:rank] <= got) and np.all(work[rank:n] >= got)
        assert np.array_equal(np.sort(work[:n]), np.sort(values[:n]))
        assert np.array_equal(work[n:], values[n:])


@pytest.mark.parametrize("count", [1, 2, 3, 10, 11, 400])
def test_median_equals_numpys(count):
    values = np.random.default_rng(count).integers(0, 9, size=count).astype(np.float64)
    assert median(values.copy(), count) == np.median(values)
