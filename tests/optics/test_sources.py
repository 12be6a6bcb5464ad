import numpy as np
import pytest

from sassi_bench.errors import ConfigError
from sassi_bench.optics.psf import PsfSigmaCurve, line_spread_sigma
from sassi_bench.optics.sources import (
    blackbody_power,
    broadband_samples,
    colour_illuminant_power,
    laser_samples,
    wavelength_grid,
)


def test_laser_line_has_its_centre_width_and_flux():
    s = laser_samples(532.0, fwhm_nm=2.0, flux=5e5)
    assert s.weights.sum() == pytest.approx(5e5)
    assert s.mean_wavelength_nm == pytest.approx(532.0, abs=1e-9)
    var = np.sum(s.weights * (s.wavelengths_nm - 532.0) ** 2) / s.weights.sum()
    assert np.sqrt(var) * 2 * np.sqrt(2 * np.log(2)) == pytest.approx(2.0, rel=1e-9)
    with pytest.raises(ConfigError):
        laser_samples(532.0, 0.0, 1.0)


def test_broadband_flux_is_normalised_in_band_and_counts_photons():
    grid = wavelength_grid(390, 720, 2)
    s = broadband_samples(np.ones_like(grid), grid, 1e6)
    band = (grid >= 400) & (grid <= 700)
    assert s.weights[band].sum() == pytest.approx(1e6)
    # Flat power carries more photons at long wavelengths (E = hc / lambda).
    assert s.weights[grid == 700][0] / s.weights[grid == 400][0] == pytest.approx(1.75)


def test_halogen_is_red_heavy_and_led_has_no_deep_blue():
    grid = wavelength_grid(390, 720, 2)
    halogen = blackbody_power(grid, 3000)
    assert np.all(np.diff(halogen) > 0)
    led = colour_illuminant_power("LED-B3", grid)
    assert led[grid == 400][0] < 0.05 * led.max()
    with pytest.raises(ConfigError):
        colour_illuminant_power("LED-XX", grid)


def test_blur_through_three_points_is_the_quadratic():
    blur = PsfSigmaCurve({405: 1.7, 520: 0.42, 635: 1.7})
    assert blur([405, 520, 635]) == pytest.approx([1.7, 0.42, 1.7])
    assert blur(577.5) == pytest.approx(0.42 + 1.28 * 0.25)


def test_blur_with_more_points_is_smooth_and_not_quadratic():
    points = {400: 2.0, 480: 0.8, 550: 0.5, 640: 1.2, 700: 2.5}
    blur = PsfSigmaCurve(points)
    assert blur(list(points)) == pytest.approx(list(points.values()))
    lam = np.linspace(400, 700, 61)
    quad = np.polyval(np.polyfit(list(points), list(points.values()), 2), lam)
    assert np.max(np.abs(blur(lam) - quad)) > 0.05


def test_blur_rejects_too_few_points():
    with pytest.raises(ConfigError, match="three"):
        PsfSigmaCurve({400: 1.0, 500: 1.0})


def test_line_spread_adds_aperture_and_pixel_variances():
    assert line_spread_sigma(0.5, 1.0, 1.0) == pytest.approx(np.sqrt(0.25 + 2 / 12))
