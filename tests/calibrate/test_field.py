import numpy as np
import pytest

from sassi_bench.calibrate.field import fit_field


def test_robust_fit_ignores_outliers_and_reports_them():
    rng = np.random.default_rng(0)
    u, v = rng.uniform(0, 639, 4000), rng.uniform(0, 399, 4000)
    truth = 50 + 1.08 * u + 0.003 * u * v / 400 + 2e-6 * u**2
    values = truth + rng.normal(0, 0.02, u.size)
    bad = rng.choice(u.size, 200, replace=False)
    values[bad] += rng.uniform(5, 50, bad.size)
    fit = fit_field(u, v, values, (400, 640), degree=3)
    assert np.abs(fit(u, v) - truth).max() < 0.01
    assert fit.rms == pytest.approx(0.02, rel=0.15)
    assert not fit.inliers[bad].any()
    assert fit.n_inliers == pytest.approx(3800, abs=20)


def test_too_few_samples_is_a_clear_error():
    with pytest.raises(ValueError, match="cannot constrain a degree-5 polynomial"):
        fit_field([1, 2, 3], [1, 2, 3], [1, 2, 3], (400, 640), degree=5)


def test_thinned_solve_reports_residuals_over_every_sample():
    from sassi_bench.maths.legendre import field_coordinates, legendre2d_design

    rng = np.random.default_rng(5)
    n = 150_000  # several residual blocks, thinned for the solve
    u, v = rng.uniform(0, 639, n), rng.uniform(0, 399, n)
    values = 3 + 0.01 * u - 2e-5 * v**2 + rng.normal(0, 0.05, n)
    values[::97] += 5.0  # outliers
    fit = fit_field(u, v, values, (400, 640), degree=3, max_samples=20_000)
    residual = values - legendre2d_design(*field_coordinates(u, v, (400, 640)), 3) @ fit.coeffs
    assert fit.inliers.size == n and not fit.inliers[::97].any()
    assert fit.rms == pytest.approx(np.sqrt(np.mean(residual[fit.inliers] ** 2)), rel=1e-12)
    assert fit.rms == pytest.approx(0.05, rel=0.05)
