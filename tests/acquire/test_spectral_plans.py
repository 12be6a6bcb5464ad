"""The blur frames' pinhole pattern reaches the SLM's edges."""

import numpy as np
import pytest

from sassi_bench.acquire.patterns import open_pixels
from sassi_bench.acquire.spectral_plans import blur_pinholes


@pytest.mark.parametrize(
    ("pitch", "shape"), [([40, 40], (200, 320)), ([26, 26], (400, 640)), ([33, 17], (480, 640))]
)
def test_blur_pinholes_span_the_field_at_least_the_pitch_apart(pitch, shape):
    pattern = blur_pinholes(pitch, shape)
    rows, cols = open_pixels(pattern, shape)
    for got, size, least in ((cols, shape[1], pitch[0]), (rows, shape[0], pitch[1])):
        at = np.unique(got)
        assert np.diff(at).min() >= least
        # the outermost pinholes within a pitch's remainder of the edges
        assert at[0] <= (size - 1) % least and at[-1] >= size - 1 - (size - 1) % least
        assert at.size == (size - 1) // least + 1


def test_a_pitch_wider_than_the_slm_keeps_one_pinhole_in_the_middle():
    rows, cols = open_pixels(blur_pinholes([400, 40], (200, 320)), (200, 320))
    assert set(cols.tolist()) == {160}
    assert rows.min() <= 3 and rows.max() >= 196
