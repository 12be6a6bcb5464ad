"""The dispersion fit's stated 1-sigma: in camera px the worst over the band, and in nm
wavelength by wavelength."""

import numpy as np
import pytest

from sassi_bench.calibrate.dispersion import LaserMap, fit_dispersion
from sassi_bench.calibrate.field import fit_field
from sassi_bench.rig.sim import truth

# Lines from 473 nm up, as on a bench without a violet laser: the map reaches past them
# furthest at the blue end, where the dispersion is steepest.
LINES_NM = [473.0, 523.0, 532.0, 594.0, 641.0]


@pytest.fixture(scope="module")
def noisy_fit(sim_rig):
    """Laser maps fitted to the true trace plus 0.3 px of scatter per correspondence."""
    bench = truth(sim_rig)
    h, w = sim_rig.slm.shape
    v, u = np.mgrid[0:h:10, 0:w:10].astype(float)
    rng = np.random.default_rng(3)
    maps = []
    for nm in LINES_NM:
        x, y = bench.slm_to_camera(u, v, nm)
        x = x + rng.normal(0.0, 0.3, x.shape)
        y = y + rng.normal(0.0, 0.3, y.shape)
        fx = fit_field(u.ravel(), v.ravel(), x.ravel(), (h, w), 5)
        fy = fit_field(u.ravel(), v.ravel(), y.ravel(), (h, w), 5)
        maps.append(LaserMap(nm, fx, fy, x.size))
    return fit_dispersion(maps, "N-BK7", (h, w))


def _centre_slopes(fit) -> np.ndarray:
    h, w = fit.model.slm_shape
    lam = np.linspace(400.0, 700.0, 301)
    x, _ = fit.model.evaluate((w - 1) / 2, (h - 1) / 2, lam)
    return np.abs(np.gradient(np.ravel(x), lam))


def test_the_stated_sigma_in_nm_is_taken_wavelength_by_wavelength(noisy_fit):
    slopes = _centre_slopes(noisy_fit)
    worst_px = noisy_fit.position_sigma_px
    # The worst column 1-sigma (at the blue end) over the steepest dispersion bounds it
    # from below; the old reading, that 1-sigma over the red end's dispersion, states
    # one the map has at no wavelength: more than twice as large here.
    assert noisy_fit.position_sigma_nm >= worst_px / slopes.max() * 0.99
    assert noisy_fit.position_sigma_nm < 0.5 * worst_px / slopes.min()
