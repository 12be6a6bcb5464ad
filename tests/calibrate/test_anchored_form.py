"""The anchored fit's form error: its miss, with no noise, on optics its form cannot follow."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from sassi_bench.calibrate.anchored import (
    _Spectral,
    fit_anchored_wavelengths,
)
from sassi_bench.calibrate.anchored_form import BAND_SAMPLES, anchored_form_error_px
from sassi_bench.calibrate.dispersion import BAND_NM
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design
from sassi_bench.optics.glass import get_glass

SLM = (48, 64)
GLASS = get_glass("N-SF11")
SPECTRAL = _Spectral(GLASS, 2)
LASERS = (450.0, 520.0, 532.0, 635.0)


def _column(cubic: float):
    """An arm whose column is a quadratic in the index plus ``cubic`` px of its cube."""

    def column(u, v, lam):
        s = SPECTRAL.s(np.asarray(lam, dtype=np.float64))
        return 120.0 + 1.15 * u + 0.02 * v - 85.0 * s + 4.0 * s**2 + cubic * s**3

    return column


def _sigma_px(lam):
    return np.polyval(np.polyfit([405.0, 530.0, 660.0], [1.44, 0.99, 2.32], 2), lam)


def _fit(build, column, seed):
    rng = np.random.default_rng(seed)
    maps = [
        SimpleNamespace(wavelength_nm=label, x=lambda u, v, lam=label: column(u, v, lam))
        for label in LASERS
    ]
    lamps = [build(name, column, _sigma_px, rng) for name in ("HgAr", "Ne")]
    fit = fit_anchored_wavelengths(maps, lamps, GLASS, SLM, [5.0] * 4, field_degree=1)
    return fit, lamps


def _miss_px(fit, column):
    """The fit's column RMS distance from the arm over the field, per band wavelength."""
    u, v = (g.ravel() for g in np.meshgrid(np.linspace(0, 63, 17), np.linspace(0, 47, 11)))
    band = np.linspace(*BAND_NM, BAND_SAMPLES)
    field = legendre2d_design(*field_coordinates(u, v, SLM), 1)
    fitted = (field @ fit.x_coeffs.T) @ SPECTRAL.powers(band).T
    return np.sqrt(np.mean((fitted - column(u[:, None], v[:, None], band[None, :])) ** 2, 0))


def test_an_arm_the_form_follows_has_no_form_error(synthetic_lamp_streaks):
    column = _column(0.0)
    fit, lamps = _fit(synthetic_lamp_streaks, column, 1)
    error = anchored_form_error_px(fit, lamps, GLASS, SLM, [5.0] * 4, column, field_degree=1)
    assert error.shape == (BAND_SAMPLES,)
    # measured: below 1e-4 px (the fit's convergence)
    assert error.max() < 1e-3


@pytest.mark.parametrize("cubic", [1.5, -1.0])
def test_the_form_error_is_the_miss_the_noisy_fit_makes(synthetic_lamp_streaks, cubic):
    """Described as the bench is built: the noisy fits miss the arm by what the form
    error states, wavelength by wavelength (the photon noise is far smaller here)."""
    column = _column(cubic)
    fit, lamps = _fit(synthetic_lamp_streaks, column, 2)
    error = anchored_form_error_px(fit, lamps, GLASS, SLM, [5.0] * 4, column, field_degree=1)
    miss = _miss_px(fit, column)
    # measured: at the red end the form error is 0.21 / 0.18 px and the noisy fits miss by
    # 0.24 / 0.16 px (the same fit of the quadratic arm misses by 0.03 px: photon noise)
    assert error.max() > 0.1
    np.testing.assert_allclose(error, miss, atol=0.2 * error.max())
