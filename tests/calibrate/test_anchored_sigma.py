"""The lasers' uncertainty in the lamp-anchored fit, with blended lamp lines."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from sassi_bench.calibrate.anchored import _Problem, _State


def _problem(normal, amplitudes):
    size = normal.shape[0]
    lamp = SimpleNamespace(chi2=lambda residual: 0.5)  # below 1: no scaling
    problem = SimpleNamespace(size=size, lasers=slice(2, 4), amplitudes=[amplitudes], lamps=[lamp])
    state = _State(np.ones(size), [], [], normal=normal, residuals=[np.zeros(1)])
    return problem, state


def test_laser_sigma_is_the_inverse_s_diagonal_when_every_unknown_is_known():
    rng = np.random.default_rng(3)
    jacobian = rng.normal(size=(40, 8))
    normal = jacobian.T @ jacobian
    problem, state = _problem(normal, slice(4, 8))
    sigma = _Problem.laser_sigma(problem, state)
    np.testing.assert_allclose(sigma, np.sqrt(np.diag(np.linalg.inv(normal))[2:4]), rtol=1e-10)


def test_two_lines_on_the_same_pixels_leave_the_lasers_known():
    """Two amplitudes with one column: only their sum is known, the normal matrix is
    singular, and the lasers' uncertainty is that of the fit with the lines merged."""
    rng = np.random.default_rng(4)
    jacobian = rng.normal(size=(40, 7))
    blended = np.concatenate([jacobian, jacobian[:, 6:7]], axis=1)  # column 7 = column 6
    problem, state = _problem(blended.T @ blended, slice(4, 8))
    merged, merged_state = _problem(jacobian.T @ jacobian, slice(4, 7))
    sigma = _Problem.laser_sigma(problem, state)
    np.testing.assert_allclose(sigma, _Problem.laser_sigma(merged, merged_state), rtol=1e-8)
