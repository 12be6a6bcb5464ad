"""The compiled sensor-noise sampler: its random bits, its Poisson and normal draws.

The Poisson draws are checked at means chosen to exercise every branch of the sampler
(the quarter-mean inversion, the fine tables, PD) and the edges between them: mean,
variance and a chi-square goodness of fit against the exact pmf. The same statistic
rejects the rounded-normal approximation, so the test can fail. PD's rare exact
acceptance steps are checked on their own (many draws of means where they are taken
most often), and the pmf they use against scipy's.
"""

from __future__ import annotations

import math
from decimal import Decimal, getcontext

import numpy as np
import pytest
from scipy import stats

from sassi_bench.optics import _noise_kernels as kernels
from sassi_bench.optics import sensor as sensor_module
from sassi_bench.optics.sensor import SensorModel

DRAWS = 200_000
MEANS = [
    1e-3, 0.1, 0.2499, 0.25, 0.6, 1.0, 3.3, 9.99, 10.0, 31.99, 32.0, 32.7, 46.0, 300.7,
    2000.0, 20000.0, 40000.0, 1e6,
]  # fmt: skip


def _state(seed: int) -> np.ndarray:
    return kernels.seed_state(np.random.SeedSequence(seed))


def _chi_square_p(draws: np.ndarray, mean: float) -> float:
    """p-value of a chi-square test of ``draws`` against Poisson(``mean``), on bins of
    consecutive counts merged until each expects at least 20 draws."""
    dist = stats.poisson(mean)
    low, high = int(dist.ppf(1e-7)), int(dist.isf(1e-7)) + 1
    edges = [low]
    expected_in_bin = 0.0
    for k in range(low, high + 1):
        expected_in_bin += dist.pmf(k) * draws.size
        if expected_in_bin >= 20:
            edges.append(k + 1)
            expected_in_bin = 0.0
    edges[-1] = high + 1
    edges = np.array(edges)
    observed = np.histogram(np.clip(draws, low, high), bins=edges)[0]
    cdf = dist.cdf(edges - 1)
    cdf[0], cdf[-1] = 0.0, 1.0
    expected = np.diff(cdf) * draws.size
    if expected.size < 2:  # all mass in one bin: the draws must all be there
        return 1.0 if observed[0] == draws.size else 0.0
    return float(stats.chisquare(observed, expected).pvalue)


def test_the_random_bits_are_numpys_sfc64():
    sequence = np.random.SeedSequence([3, 1, 4])
    ours = kernels.sfc64_raw(kernels.seed_state(sequence), 10_000)
    numpys = np.random.SFC64(np.random.SeedSequence([3, 1, 4])).random_raw(10_000)
    assert np.array_equal(ours, numpys)


def _log_pmf_40_digits(k: int, lam: float) -> float:
    """``log P(X = k)``, X ~ Poisson(lam), in 40-digit decimals: ``log k!`` exactly below
    40, above by Stirling's series to the k**-15 term (truncation below 1e-28)."""
    getcontext().prec = 40
    if k < 40:
        log_factorial = Decimal(math.factorial(k)).ln()
    else:
        n = Decimal(k)
        pi = Decimal("3.141592653589793238462643383279502884197")
        log_factorial = (n + Decimal("0.5")) * n.ln() - n + (2 * pi).ln() / 2
        bernoulli = [
            (1, 6),
            (-1, 30),
            (1, 42),
            (-1, 30),
            (5, 66),
            (-691, 2730),
            (7, 6),
            (-3617, 510),
        ]
        for i, (num, den) in enumerate(bernoulli, start=1):
            log_factorial += Decimal(num) / (den * 2 * i * (2 * i - 1) * n ** (2 * i - 1))
    x = Decimal(float(lam))
    return float(k * x.ln() - x - log_factorial)


def test_the_pmf_of_the_acceptance_tests_is_exact_to_double_precision():
    """Against 40-digit arithmetic (scipy's ``logpmf`` itself is off by 3e-9 at 1e7)."""
    rng = np.random.default_rng(0)
    lam = np.exp(rng.uniform(np.log(kernels.TABLE_MAX), np.log(1e7), 2000))
    k = np.maximum(0, np.rint(lam + rng.normal(0, 4, lam.size) * np.sqrt(lam))).astype(np.int64)
    k[:50] = np.arange(50)  # the small counts (a tabulated Stirling term) and 0
    ours = kernels.poisson_log_pmf(k, lam)
    exact = np.array([_log_pmf_40_digits(int(a), float(b)) for a, b in zip(k, lam, strict=True)])
    assert np.max(np.abs(ours - exact) / np.maximum(1.0, np.abs(exact))) < 1e-12


@pytest.mark.parametrize("mean", [kernels.TABLE_MAX, 100.0])
def test_pd_is_exact_where_its_slow_steps_are_taken_most(mean):
    """At small means PD's immediate acceptance is rarest: about a tenth of the draws go
    through its exact tests (steps Q, E and H). 4 million draws resolve a relative
    error of about 1 % in the probability of a count that costs a tenth of a per cent."""
    draws = kernels.poisson_draws(_state(round(mean) + 7), np.full(4_000_000, mean))
    assert abs(draws.mean() - mean) < 5 * np.sqrt(mean / draws.size)
    assert abs(draws.var(ddof=1) - mean) < 5 * np.sqrt((mean + 2 * mean**2) / draws.size)
    assert _chi_square_p(draws, mean) > 1e-4


@pytest.mark.parametrize("mean", MEANS)
def test_poisson_draws_have_the_mean_variance_and_distribution_of_poisson(mean):
    draws = kernels.poisson_draws(_state(round(mean * 1000) + 1), np.full(DRAWS, mean))
    assert draws.dtype == np.int64 and draws.min() >= 0
    # Mean and variance within 5 standard errors (the fourth moment of a Poisson is
    # mean (1 + 3 mean), so the sample variance's error is about sqrt((mean + 2 mean^2) / n)).
    assert abs(draws.mean() - mean) < 5 * np.sqrt(mean / DRAWS)
    assert abs(draws.var(ddof=1) - mean) < 5 * np.sqrt((mean + 2 * mean**2) / DRAWS)
    assert _chi_square_p(draws, mean) > 1e-4


@pytest.mark.parametrize("mean", [3.3, 46.0, 300.7])
def test_the_goodness_of_fit_rejects_the_normal_approximation(mean):
    """The same test on rounded normal draws fails: it has the power to tell (up to a
    few hundred electrons; far above, the two laws differ by less than it can see)."""
    rng = np.random.default_rng(5)
    approx = np.maximum(0, np.rint(rng.normal(mean, np.sqrt(mean), 2 * DRAWS))).astype(int)
    assert _chi_square_p(approx, mean) < 1e-6


def test_draws_of_mixed_means_are_poisson_and_uncorrelated():
    rng = np.random.default_rng(8)
    means = np.exp(rng.uniform(np.log(1e-3), np.log(1e5), 1_000_000))
    draws = kernels.poisson_draws(_state(21), means)
    z = (draws - means) / np.sqrt(means)
    assert abs(z.mean()) < 5 / np.sqrt(z.size)
    assert abs(z.var() - 1) < 0.02
    assert abs(np.corrcoef(z[:-1], z[1:])[0, 1]) < 5 / np.sqrt(z.size)
    # Probability integral transform (randomised for a discrete law) is uniform.
    pit = stats.poisson.cdf(draws - 1, means) + rng.uniform(size=draws.size) * stats.poisson.pmf(
        draws, means
    )
    assert stats.kstest(pit, "uniform").pvalue > 1e-4


def test_normal_draws_are_standard_normal_including_the_tail():
    z = kernels.standard_normal_draws(_state(31), 2_000_000)
    assert abs(z.mean()) < 5 / np.sqrt(z.size)
    assert abs(z.var() - 1) < 5 * np.sqrt(2 / z.size)
    assert stats.kstest(z, "norm").pvalue > 1e-4
    # The ziggurat's base layer draws |z| beyond r = 3.654 from its own tail method.
    tail = np.mean(np.abs(z) > kernels._ZIG_R)
    expected = 2 * stats.norm.sf(kernels._ZIG_R)
    assert abs(tail - expected) < 5 * np.sqrt(expected / z.size)
    beyond = np.abs(z[np.abs(z) > kernels._ZIG_R])
    conditional = (stats.norm.sf(beyond) / stats.norm.sf(kernels._ZIG_R)).clip(0, 1)
    assert stats.kstest(conditional, "uniform").pvalue > 1e-4


def test_a_frame_does_not_depend_on_the_number_of_threads(monkeypatch):
    from concurrent.futures import ThreadPoolExecutor

    sensor = SensorModel(read_noise_e=5.0, full_well_e=30000.0, bit_depth=16)
    rate = np.random.default_rng(2).uniform(0, 2e6, (123, 77)).astype(np.float32)
    many = sensor.expose(rate, 0.01, np.random.default_rng([4, 4]))
    with ThreadPoolExecutor(max_workers=1) as one:
        monkeypatch.setattr(sensor_module, "_pool", lambda: one)
        single = sensor.expose(rate, 0.01, np.random.default_rng([4, 4]))
    assert np.array_equal(many, single)


def test_a_nan_rate_is_refused():
    sensor = SensorModel(read_noise_e=5.0, full_well_e=30000.0, bit_depth=16)
    rate = np.ones((8, 8), np.float32)
    rate[5, 5] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        sensor.expose(rate, 0.01, np.random.default_rng(0))
