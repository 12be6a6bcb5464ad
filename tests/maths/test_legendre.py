"""The field basis of the model contract, against closed forms independent of numpy.polynomial."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.maths.legendre import (
    field_coordinates,
    horner,
    legendre2d_design,
    legendre2d_terms,
)

LEGENDRE = [
    lambda t: np.ones_like(t),
    lambda t: t,
    lambda t: (3 * t**2 - 1) / 2,
    lambda t: (5 * t**3 - 3 * t) / 2,
]
TERMS_DEGREE_3 = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3)]


def test_legendre2d_terms_order():
    assert list(legendre2d_terms(3)) == TERMS_DEGREE_3
    assert legendre2d_terms(0) == ((0, 0),)
    assert len(legendre2d_terms(5)) == 21


@pytest.mark.parametrize("degree", [-1, 2.0, True, "2"])
def test_legendre2d_terms_refuses_a_degree_that_is_not_a_whole_number(degree):
    with pytest.raises(ValueError, match="integer >= 0"):
        legendre2d_terms(degree)


def test_legendre2d_design_matches_closed_forms():
    rng = np.random.default_rng(0)
    uh, vh = rng.uniform(-1, 1, (2, 7, 3))
    design = legendre2d_design(uh, vh, 3)
    assert design.shape == (7, 3, 10)
    for t, (i, j) in enumerate(TERMS_DEGREE_3):
        np.testing.assert_allclose(design[..., t], LEGENDRE[i](uh) * LEGENDRE[j](vh), atol=1e-14)


def test_legendre2d_design_broadcasts_and_keeps_scalars_scalar():
    design = legendre2d_design(np.linspace(-1, 1, 4)[:, None], np.linspace(-1, 1, 5), 2)
    assert design.shape == (4, 5, 6)
    assert legendre2d_design(0.3, -0.2, 2).shape == (6,)


def test_field_coordinates_span_minus_one_to_one():
    uh, vh = field_coordinates([0, 319.5, 639], [0, 199.5, 399], (400, 640))
    np.testing.assert_allclose(uh, [-1, 0, 1])
    np.testing.assert_allclose(vh, [-1, 0, 1])


def test_horner_matches_the_power_series_with_stacked_coefficients():
    rng = np.random.default_rng(2)
    coeffs = rng.normal(size=(3, 4, 1))  # power, then a field axis that broadcasts with s
    s = rng.uniform(-1, 1, 5)
    expected = coeffs[0] + coeffs[1] * s + coeffs[2] * s**2
    out = horner(s, coeffs)
    assert out.shape == (4, 5) and out.dtype == np.float64
    np.testing.assert_allclose(out, expected, rtol=1e-14, atol=1e-14)
    assert horner(0.5, np.array([2.0])).tolist() == 2.0  # a constant series
