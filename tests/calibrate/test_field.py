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
