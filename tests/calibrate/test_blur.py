import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.patterns import pinhole_pattern
from sassi_bench.calibrate.blur import fit_blur, measure_spot_widths
from sassi_bench.rig.sim import truth


def _spots(sigma, rng, peak=1000.0):
    yy, xx = np.mgrid[0:200, 0:300]
    cx = np.tile(np.arange(30, 280, 40), 4) + rng.uniform(-0.5, 0.5, 28)
    cy = np.repeat(np.arange(30, 190, 45), 7) + rng.uniform(-0.5, 0.5, 28)
    image = np.zeros(yy.shape)
    for x, y in zip(cx, cy, strict=True):  # 28 synthetic spots
        image += peak * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * sigma**2))
    return image + rng.normal(0, 1.0, image.shape), cx, cy


@pytest.mark.parametrize("sigma", [0.7, 1.5, 3.0])
def test_spot_widths_are_measured_from_a_rough_guess(sigma):
    rng = np.random.default_rng(1)
    image, cx, cy = _spots(sigma, rng)
    widths = measure_spot_widths(image, cx, cy, sigma_guess=1.5)
    assert widths.valid.all()
    assert widths.median_sigma_y == pytest.approx(sigma, rel=0.002)  # measured 0.03-0.10 %


def test_saturated_spots_are_left_out():
    rng = np.random.default_rng(2)
    image, cx, cy = _spots(1.0, rng)
    saturated = np.zeros(image.shape, bool)
    saturated[int(cy[3]), int(cx[3])] = True
    widths = measure_spot_widths(image, cx, cy, 1.0, saturated=saturated)
    assert widths.valid.sum() == 27 and not widths.valid[3]


def test_quadratic_blur_fit_and_its_residual():
    lam = np.array([450.0, 520.0, 532.0, 635.0, 670.0])
    sigma = 0.6 + 1e-4 * (lam - 530) ** 2
    fit = fit_blur(lam, sigma + np.array([0.01, -0.01, 0.0, 0.01, -0.01]))
    assert fit.model.sigma(600.0) == pytest.approx(0.6 + 1e-4 * 70**2, abs=0.03)
    assert 0 < fit.rms_px < 0.02
    with pytest.raises(ValueError, match="a quadratic needs three"):
        fit_blur([450, 600], [1.0, 1.0])


LASERS_NM = np.array([450.0, 520.0, 532.0, 635.0, 670.0])
BAND_NM = np.arange(450.0, 691.0, 10.0)


@pytest.mark.parametrize("rig_name", ["sim", "tests/rigs/prism-nbk7.yaml"])
def test_psf_quadratic_follows_the_true_blur_between_the_lasers(rig_name):
    """Spot widths exactly the bench's at its five lasers (the measurement's bias is
    tested below): the paper's quadratic through them is 3-5 % off the true width
    between 550 and 630 nm, where no laser is; the PSF's quadratic with the SLM pixel's
    image in quadrature follows the bench's spot before the camera pixel everywhere from
    450 to 690 nm, and predicts the measured widths."""
    rig = open_rig(rig_name)
    t, desc = truth(rig), rig.description
    rng = np.random.default_rng(3)
    measured = t.line_spread_sigma_px(LASERS_NM) * (1 + rng.normal(0, 0.002, LASERS_NM.size))
    aperture = desc.slm.fill_factor * desc.relay.scale
    spot = t.line_spread_sigma_px(BAND_NM)
    before_camera = np.sqrt(spot**2 - 1 / 12)
    paper = fit_blur(LASERS_NM, measured).model.sigma(BAND_NM) / spot - 1
    psf = fit_blur(LASERS_NM, measured, aperture_px=aperture)
    error = psf.model.sigma(BAND_NM) / before_camera - 1
    assert np.abs(paper).max() > 0.03  # the cause, as measured on the chain's bundle
    # A 0.2 % width noise allows about 0.6 %; measured 0.41 % (sim), 0.40 % (N-BK7 rig).
    assert np.abs(error).max() < 0.008
    assert psf.model.kind == "psf_quadratic" and psf.rms_px < 0.01
    # The PSF itself is the bench's.
    psf_true = t.blur_sigma_px(BAND_NM)
    fitted = np.sqrt(psf.model.sigma(BAND_NM) ** 2 - psf.model.pixel_variance_px2)
    assert np.abs(fitted - psf_true).max() < 0.0085  # px; measured 0.0040 and 0.0043


def test_blur_fit_refuses_spots_narrower_than_the_pixel_boxes():
    with pytest.raises(ValueError, match="no wider than the pixel boxes"):
        fit_blur(LASERS_NM, [1.0, 0.5, 0.6, 1.7, 2.6], aperture_px=1.6)


@pytest.mark.parametrize("laser", [450.0, 532.0, 670.0])
def test_spot_widths_under_a_laser_are_the_benchs(sim_rig, laser):
    """The width measurement itself is unbiased at the lasers (within 0.15 % of the
    bench's spot width from its narrowest, 0.6 px, to its widest, 2.6 px; measured
    0.015 % at 450 nm, 0.076 % at 532 nm, 0.036 % at 670 nm)."""
    rig = sim_rig
    rig.set_scene("white")
    rig.light.select(f"laser:{laser:g}")
    true = float(truth(rig).line_spread_sigma_px(laser))
    rig.spectral_camera.set_exposure(0.02 * (true / 0.6) ** 2)  # peaks at about half full
    rig.slm.show(np.zeros(rig.slm.shape, bool))
    dark = np.mean([rig.spectral_camera.capture().as_float() for _ in range(2)], axis=0)
    pattern = pinhole_pattern(rig.slm.shape, pitch=(40, 40), offset=(20, 20))
    rig.slm.show(pattern)
    lit = np.mean([rig.spectral_camera.capture().as_float() for _ in range(2)], axis=0)
    rows, cols = np.nonzero(pattern)
    x, y = truth(rig).slm_to_camera(cols, rows, laser)
    widths = measure_spot_widths(lit - dark, x, y, 1.5)
    assert widths.valid.mean() > 0.9
    assert widths.median_sigma_y == pytest.approx(true, rel=0.0015)


@pytest.mark.parametrize("rig_name", ["sim", "tests/rigs/prism-sf10.yaml"])
@pytest.mark.parametrize("kind", ["quadratic", "psf_quadratic"])
def test_the_fits_own_error_estimate_bounds_its_error_where_no_laser_is(rig_name, kind):
    """The leave-one-out error against the fit's true error over 450-690 nm, RMS: 0.56 %
    against 0.24 % for the PSF's quadratic on sim, 11.5 % against 8.3 % on the SF10 rig
    (a four-point curve no quadratic follows); 8.8 / 2.2 % and 17.1 / 8.5 % for the
    paper's quadratic. Pessimistic, never by more than a factor of four."""
    rig = open_rig(rig_name)
    t, desc = truth(rig), rig.description
    measured = t.line_spread_sigma_px(LASERS_NM) * (
        1 + np.random.default_rng(3).normal(0, 0.002, LASERS_NM.size)
    )
    if kind == "quadratic":
        fit = fit_blur(LASERS_NM, measured)
        truth_width = t.line_spread_sigma_px(BAND_NM)
    else:
        fit = fit_blur(LASERS_NM, measured, aperture_px=desc.slm.fill_factor * desc.relay.scale)
        truth_width = np.sqrt(t.line_spread_sigma_px(BAND_NM) ** 2 - 1 / 12)
    actual = np.sqrt(np.mean((fit.model.sigma(BAND_NM) / truth_width - 1) ** 2))
    assert fit.model.kind == kind
    assert actual < fit.model.relative_error < 4.5 * actual


def test_the_error_estimate_is_the_leave_one_out_rms():
    lam = np.array([450.0, 520.0, 532.0, 635.0, 670.0])
    widths = np.array([1.3, 0.8, 0.78, 1.5, 2.3])
    missed = []
    for i in range(5):
        keep = np.delete(np.arange(5), i)
        coeffs = np.polynomial.polynomial.polyfit((lam[keep] - 550.0) / 150.0, widths[keep], 2)
        predicted = np.polynomial.polynomial.polyval((lam[i] - 550.0) / 150.0, coeffs)
        missed.append(predicted / widths[i] - 1)
    fit = fit_blur(lam[::-1], widths[::-1])  # any order
    assert fit.model.relative_error == pytest.approx(np.sqrt(np.mean(np.square(missed))))
    assert fit_blur(lam[:3], widths[:3]).model.relative_error is None  # nothing to leave out


@pytest.mark.parametrize("aperture_px", [None, 1.0])
def test_residuals_are_the_measured_widths_against_what_a_camera_would_measure(aperture_px):
    widths = np.array([1.3, 0.8, 0.78, 1.5, 2.3])
    fit = fit_blur(LASERS_NM, widths, aperture_px=aperture_px)
    np.testing.assert_allclose(fit.residual_px, fit.camera_width_px(LASERS_NM) - widths)
    camera = 0.0 if aperture_px is None else 1.0 / 12.0  # the camera pixel's box, psf only
    np.testing.assert_allclose(
        fit.camera_width_px(LASERS_NM) ** 2, fit.model.sigma(LASERS_NM) ** 2 + camera
    )
