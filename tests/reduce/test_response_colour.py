"""The colour error of a response's noise, linearised, against noisy responses drawn from
its covariance and their CIEDE2000 computed exactly."""

import numpy as np
import pytest

from sassi_bench.errors import ProcedureError
from sassi_bench.reduce.response_colour import ColourChart, de00_metric, response_colour_error
from sassi_bench.validate.colorimetry import (
    delta_e2000,
    reflectance_to_lab,
    reflectance_to_xyz,
    white_chromaticity,
)
from sassi_bench.validate.reference import reference_chart

EDGES = np.linspace(400.0, 720.0, 69)
CENTRES = (EDGES[1:] + EDGES[:-1]) / 2
# The ColorChecker as the Macbeth validation computes its colour (as run_response builds it).
CHART = ColourChart(
    reference_chart().bin_average(EDGES),
    reflectance_to_xyz(CENTRES, np.eye(CENTRES.size)),
    white_chromaticity(),
)


def _halogen_like_covariance() -> np.ndarray:
    """A white's relative covariance as a halogen's: noise rising tenfold into the blue,
    neighbouring bins anticorrelated as a deblur leaves them."""
    relative = 0.001 + 0.01 * np.exp(-(CENTRES - 400.0) / 60.0)
    k = np.arange(CENTRES.size)
    correlation = np.eye(k.size) - 0.3 * (np.abs(k[:, None] - k[None]) == 1)
    return relative[:, None] * relative[None] * correlation


def test_the_linearised_colour_error_agrees_with_noisy_responses_computed_exactly():
    covariance = _halogen_like_covariance()
    linear = response_colour_error(covariance, CHART)
    reflectance = CHART.reflectance
    rng = np.random.default_rng(7)
    draws = 4000
    error = rng.standard_normal((draws, CENTRES.size)) @ np.linalg.cholesky(covariance).T
    # Each draw's response is off by (1 + error): the reflectance measured through it.
    measured = reflectance[None] / (1.0 + error[:, None, :])
    lab = reflectance_to_lab(CENTRES, measured.reshape(-1, CENTRES.size)).reshape(draws, 24, 3)
    exact = delta_e2000(lab, np.broadcast_to(reflectance_to_lab(CENTRES, reflectance), lab.shape))
    rms = np.sqrt(np.mean(exact**2, axis=0))
    # Sampling alone leaves about 1 % on each patch's RMS (4000 draws); measured: 0.45 % at
    # worst, 0.2 % on the mean.
    assert linear.mean == pytest.approx(float(np.mean(rms)), rel=0.02)
    assert np.abs(linear.per_patch / rms - 1).max() < 0.04
    assert linear.worst == pytest.approx(float(np.max(rms)), rel=0.04)


def test_the_metric_of_ciede2000_reproduces_it_for_small_changes_across_the_chart():
    lab = reflectance_to_lab(CENTRES, reference_chart().bin_average(EDGES))
    metric = de00_metric(lab)
    change = 0.05 * np.random.default_rng(3).standard_normal(lab.shape)
    quadratic = np.sqrt(np.einsum("pi,pij,pj->p", change, metric, change))
    exact = delta_e2000(lab - change / 2, lab + change / 2)
    assert np.abs(quadratic / exact - 1).max() < 1e-3
    assert np.allclose(metric, np.swapaxes(metric, 1, 2))


def test_no_noise_no_colour_error_and_bad_input_is_refused():
    assert response_colour_error(np.zeros((68, 68)), CHART).worst == 0.0
    with pytest.raises(ProcedureError, match=r"response colour error.*guard bins left out"):
        response_colour_error(np.zeros((70, 70)), CHART)
    with pytest.raises(ProcedureError, match="do not share the bins"):
        ColourChart(CHART.reflectance[:, 1:], CHART.to_xyz, CHART.white_xy)
