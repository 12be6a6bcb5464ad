"""Pattern helpers."""

import numpy as np
import pytest

from sassi_bench.acquire.patterns import PATTERN_RENDERERS, open_pixels, render_pattern
from sassi_bench.errors import ProcedureError


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


# One descriptor per kind, with its number of open pixels on a (6, 10) SLM.
EXAMPLES = {
    "blank": ({"kind": "blank"}, 0),
    "full": ({"kind": "full"}, 60),
    "uniform": ({"kind": "uniform", "level": 7}, 60),
    "gray": ({"kind": "gray", "axis": "y", "bit": 0, "block": 4, "inverse": True}, 40),
    "periodic": ({"kind": "periodic", "axis": "x", "profile": [0, 128, 255], "shift": 1}, 42),
    "lines": ({"kind": "lines", "axis": "x", "offset": 1, "spacing": 4}, 18),
    "pinholes": ({"kind": "pinholes", "pitch": [3, 2], "offset": [1, 0]}, 9),
    "pixels": ({"kind": "pixels", "rows": [0, 5], "cols": [9, 2]}, 2),
}


def test_every_registered_kind_renders_its_pattern():
    assert set(PATTERN_RENDERERS) == set(EXAMPLES)
    for kind, (descriptor, open_count) in EXAMPLES.items():
        image = render_pattern(descriptor, (6, 10))
        assert image.dtype == np.uint8 and image.shape == (6, 10), kind
        assert np.count_nonzero(image) == open_count, kind


def test_the_registry_is_read_only():
    with pytest.raises(TypeError):
        PATTERN_RENDERERS["checker"] = lambda descriptor, shape: None


@pytest.mark.parametrize(
    ("descriptor", "match"),
    [
        ({"kind": "grey", "axis": "x"}, r"unknown pattern kind 'grey' \(did you mean 'gray'\?\)"),
        ({"kind": "checkerboard"}, r"unknown pattern kind 'checkerboard'\. Fix: use blank, full"),
        ({"pitch": [3, 2]}, r"unknown pattern kind None\. Fix: .* pinholes or pixels$"),
    ],
)
def test_an_unknown_kind_names_the_closest_and_every_known_kind(descriptor, match):
    with pytest.raises(ProcedureError, match=match):
        render_pattern(descriptor, (6, 10))
