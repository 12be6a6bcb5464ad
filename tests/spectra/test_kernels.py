"""Compiled loops of the scan assembly against numpy references."""

import numpy as np
import pytest

from sassi_bench.spectra import _kernels


@pytest.mark.parametrize("dtype", [np.uint16, np.float32])
def test_reading_a_window_sums_free_pixels_cumulates_and_counts_bad_ones(dtype):
    rng = np.random.default_rng(5)
    h, w = 9, 12
    image = rng.integers(0, 4000, (h, w)).astype(dtype)
    image[1, 2] = image[7, 11] = 4095  # saturated
    finite = np.ones((h, w), dtype=bool)
    if dtype == np.float32:
        image[2, 3], image[4, 1] = np.nan, np.inf
        finite[2, 3] = finite[4, 1] = False
    # Overlapping rectangles, one empty, one reaching the right and bottom edges.
    top, bottom = np.array([0, 2, 5, 3, 6]), np.array([3, 6, 5, 4, 9])
    left, right = np.array([1, 4, 0, 3, 8]), np.array([5, 7, 9, 3, 12])
    covered = np.zeros((h, w), dtype=bool)
    for y0, y1, x0, x1 in zip(top, bottom, left, right, strict=True):
        covered[y0:y1, x0:x1] = True
    total, count = np.full((h, w), 10.0), np.ones((h, w), dtype=np.int32)
    cumulative = np.full((h + 1, w), np.nan)
    marks = np.zeros((h, w + 1), dtype=np.int32)
    rectangles = (top, bottom, left, right)
    bad = _kernels.read_window(image, *rectangles, 4095, cumulative, total, count, marks)
    use = ~covered & finite
    values = np.where(finite, image, 0).astype(np.float64)
    assert np.array_equal(total, 10.0 + np.where(use, values, 0))
    assert np.array_equal(count, 1 + use)
    assert np.array_equal(cumulative, np.vstack([np.zeros((1, w)), np.cumsum(values, axis=0)]))
    assert bad == 2 + (~finite).sum()
    assert not marks.any()  # left clean for the next frame


def test_column_weights_are_the_numpy_loop_s():
    """The compiled column weights against the whole-array loop they replaced."""
    rng = np.random.default_rng(5)
    width = 40
    x_left = rng.uniform(-3.0, width + 1.0, (50, 9))
    x_right = x_left + rng.uniform(0.0, 12.0, x_left.shape)
    x_right[0, 0] = x_left[0, 0]  # an empty bin
    total, square = np.empty_like(x_left), np.empty_like(x_left)
    _kernels.column_weights(x_left, x_right, float(width), total, square)
    left = np.clip(x_left, -0.5, width - 0.5)
    right = np.clip(x_right, -0.5, width - 0.5)
    first = np.floor(left + 0.5)
    expected_total, expected_square = np.zeros_like(left), np.zeros_like(left)
    for k in range(int(np.ceil(np.max(right - left))) + 2):
        centre = first + k
        w = np.clip(np.minimum(centre + 0.5, right) - np.maximum(centre - 0.5, left), 0.0, None)
        expected_total += w
        expected_square += w * w
    assert np.array_equal(total, expected_total) and np.array_equal(square, expected_square)
