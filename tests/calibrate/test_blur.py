import numpy as np
import pytest

from sassi_bench.calibrate.blur import fit_blur, measure_spot_widths


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
    assert widths.median_sigma_y == pytest.approx(sigma, rel=0.03)


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
