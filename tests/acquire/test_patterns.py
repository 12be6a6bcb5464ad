"""Pattern helpers."""

import numpy as np
import pytest

from sassi_bench.acquire.patterns import open_pixels, render_pattern


@pytest.mark.parametrize(
    "pattern",
    [
        {"kind": "pinholes", "pitch": [100, 5], "offset": [99, 4]},
        {"kind": "pinholes", "pitch": [7, 3]},
        {"kind": "lines", "axis": "x", "offset": 2, "spacing": 9},
        {"kind": "blank"},
    ],
)
def test_open_pixels_are_the_rendered_patterns_non_zero_pixels(pattern):
    shape = (40, 230)
    rows, cols = open_pixels(pattern, shape)
    expected = np.nonzero(render_pattern(pattern, shape))
    assert np.array_equal(rows, expected[0]) and np.array_equal(cols, expected[1])
