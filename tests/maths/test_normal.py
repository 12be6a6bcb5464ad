"""The normal distribution's integrals: the tabulated CDF against scipy, the ramp and the
box and pixel integrals against quadrature."""

import numpy as np
from scipy.integrate import quad
from scipy.special import ndtr

from sassi_bench.maths.normal import (
    CDF_STEPS_PER_UNIT,
    NORMAL_CDF_TABLE,
    box_overlap,
    pixel_spot,
    tabulated_cdf,
)


def test_tabulated_normal_cdf_matches_scipy():
    z = np.linspace(-12.0, 12.0, 100_001)
    table = np.array([tabulated_cdf(v, NORMAL_CDF_TABLE) for v in z[::7]])
    assert np.abs(table - ndtr(z[::7])).max() < 1e-10
    # Continuous where the pieces meet.
    steps = np.arange(-8.0, 8.0, 1.0 / CDF_STEPS_PER_UNIT)
    left = [tabulated_cdf(v - 1e-12, NORMAL_CDF_TABLE) for v in steps]
    right = [tabulated_cdf(v, NORMAL_CDF_TABLE) for v in steps]
    assert np.abs(np.subtract(left, right)).max() < 1e-11
    ends = [tabulated_cdf(v, NORMAL_CDF_TABLE) for v in (-np.inf, np.inf, np.nan)]
    assert ends[:2] == [0.0, 1.0] and np.isnan(ends[2])


def test_a_box_blurred_into_another_is_the_double_integral():
    sigma = 0.8
    got = box_overlap(np.array([0.0, 1.3]), np.array([1.3, 2.0]), np.array([sigma, sigma]))
    # The light of box 0 (uniform over [0, 1.3]) that lands in box 1, [1.3, 2.0].
    inner = lambda s: (ndtr((2.0 - s) / sigma) - ndtr((1.3 - s) / sigma)) / 1.3  # noqa: E731
    assert abs(got[1, 0] - quad(inner, 0.0, 1.3)[0]) < 1e-12


def test_a_pixel_spot_is_the_box_of_a_box_blurred():
    aperture, sigma, offset = 1.2, 0.7, 0.35
    value = pixel_spot(offset, aperture, sigma)[0]
    # The SLM pixel's box (side ``aperture``) blurred, integrated over one camera pixel.
    inner = lambda s: ndtr((offset + 0.5 - s) / sigma) - ndtr((offset - 0.5 - s) / sigma)  # noqa: E731
    expected = quad(inner, -aperture / 2, aperture / 2)[0] / aperture
    assert abs(float(value) - expected) < 1e-10
