"""The outlier screen's compiled window medians against numpy's sorted windows."""

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from sassi_bench.calibrate._window_median import window_medians


def test_window_medians_equal_the_sorted_windows_of_numpy():
    rng = np.random.default_rng(11)
    values = rng.normal(0.0, 1.0, (60, 80)).astype(np.float32)
    values[rng.random(values.shape) < 0.3] = np.inf  # pixels that do not count
    values[::7, ::5] = 0.25  # ties
    padded = np.pad(values, 2, constant_values=np.inf)
    rows, cols = np.nonzero(np.ones(values.shape, bool))
    median, count = window_medians(padded, rows, cols, 5)
    ordered = np.sort(sliding_window_view(padded, (5, 5))[rows, cols].reshape(rows.size, -1))
    expected_count = np.sum(np.isfinite(ordered), axis=1)
    lo = np.take_along_axis(ordered, ((expected_count - 1) // 2)[:, None], axis=1)[:, 0]
    hi = np.take_along_axis(ordered, (expected_count // 2)[:, None], axis=1)[:, 0]
    some = expected_count > 0
    assert np.array_equal(count, expected_count)
    assert np.array_equal(median[some], (0.5 * (lo + hi))[some])
    assert np.all(np.isnan(median[~some]))
