"""The field-covariance blur fitted to pinhole spots of a design rig, against its truth."""

import numpy as np
import pytest

from sassi_bench.calibrate.blur import SpotMoments, fit_field_covariance, measure_spot_widths
from sassi_bench.optics.sources import laser_samples
from sassi_bench.rig.sim import truth

LASERS = (450.0, 520.0, 532.0, 635.0, 670.0)
FWHM_NM = 1.0


def _pinhole_moments(rig, pitch=40):
    """Every pinhole's measured moments under each laser (noise-free frames), the laser's
    dispersed line width taken out along the streak."""
    t = truth(rig)
    bench = t.bench
    h, w = bench.slm_shape
    rows, cols = np.mgrid[pitch // 2 : h : pitch, pitch // 2 : w : pitch]
    rows, cols = rows.ravel(), cols.ravel()
    parts = []
    for laser in LASERS:
        line = laser_samples(laser, FWHM_NM, 1.0e6)
        rate = bench.renderer.render_sparse(
            rows, cols, np.ones(rows.size, np.float32), bench.scene_named("white"), line
        )
        x, y = t.slm_to_camera(cols, rows, laser)
        widths = measure_spot_widths(rate, x, y, 1.5)
        x_hi, _ = t.slm_to_camera(cols, rows, laser + 0.5)
        x_lo, _ = t.slm_to_camera(cols, rows, laser - 0.5)
        line_px2 = ((x_hi - x_lo) * FWHM_NM / 2.3548) ** 2
        ok = widths.valid
        parts.append(
            (cols[ok] * 1.0, rows[ok] * 1.0, np.full(ok.sum(), laser),
             widths.sigma_x[ok] ** 2 - line_px2[ok], widths.sigma_y[ok] ** 2, widths.cov_xy[ok])
        )  # fmt: skip
    return SpotMoments(*(np.concatenate(p) for p in zip(*parts, strict=True)))


@pytest.mark.parametrize("name", ["achromat", "singlet"])
def test_field_blur_follows_the_spot_over_the_field_and_band(design_rigs, name):
    rig = design_rigs(name)
    t = truth(rig)
    bench = t.bench
    spots = _pinhole_moments(rig)
    aperture2 = bench.renderer.aperture_variance
    fit = fit_field_covariance(spots, bench.slm_shape, aperture2)
    h, w = bench.slm_shape
    u, v = np.meshgrid(np.linspace(0, w - 1, 9), np.linspace(0, h - 1, 5))
    lam = np.linspace(450.0, 670.0, 23)
    cxx, cyy, cxy = t.spot_covariance(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
    spot = fit.model.spot(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
    # the truth includes the camera pixel, the model is the spot before it
    along_err = np.abs(spot.along - np.sqrt(cxx - 1 / 12))
    across_err = np.abs(spot.across - np.sqrt(cyy - 1 / 12))
    rho_true = cxy / np.sqrt((cxx - 1 / 12) * (cyy - 1 / 12))
    # a round sigma(lambda) (the widest spot over the field) for comparison
    round_err = np.abs(fit.model.sigma(lam)[None, :] - np.sqrt(cyy - 1 / 12))
    print(
        f"{name}: along max {along_err.max():.3f} px, across max {across_err.max():.3f} px, "
        f"rho max {np.abs(spot.correlation - rho_true).max():.3f}; widest-round across "
        f"max {round_err.max():.3f} px"
    )
    # measured (noise-free frames): along / across / correlation max error achromat
    # 0.019 px / 0.014 px / 0.009, singlet 0.050 px / 0.010 px / 0.057; the widest round
    # spot is 0.74 / 0.96 px off across
    assert along_err.max() < {"achromat": 0.04, "singlet": 0.10}[name]
    assert across_err.max() < {"achromat": 0.03, "singlet": 0.02}[name]
    assert np.abs(spot.correlation - rho_true).max() < {"achromat": 0.02, "singlet": 0.10}[name]
    assert across_err.max() < 0.1 * round_err.max()
