"""The blur object's contract, held by every registered form (:data:`BLUR_FORMS`).

A new form adds its example here (one instance per manifest name it answers to); every
test below then holds it to the same behaviour: per-point spots that broadcast like their
arguments, a widest width no spot exceeds, a PSF no wider than its spot, a manifest round
trip, and profile integrals that conserve light.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ndtr

from sassi_bench.bundle import BundleSchemaError
from sassi_bench.bundle.blur import BLUR_FORMS, GAUSSIAN, QuadraticBlur, blur_from_manifest
from sassi_bench.bundle.blur.field_covariance import FieldCovarianceBlur

#: One example per manifest name a registered form answers to.
EXAMPLES = {
    "psf_quadratic": QuadraticBlur(
        (0.45, 0.1, 1.3), 530.0, 150.0, 3.0, pixel_variance_px2=0.08, relative_error=0.01
    ),
    "quadratic": QuadraticBlur((1.0, 0.0, 3.0 / 1.15**2), 520.0, 100.0, 2.5),
    "field_covariance": FieldCovarianceBlur(
        np.array(
            [
                [[1.2, 0.1, 0.8], [0.3, 0.0, 0.0], [0.0, 0.1, 0.0]],  # cxx: grows to the right
                [[0.9, 0.0, 0.5], [0.0, 0.0, 0.0], [0.2, 0.0, 0.0]],  # cyy: grows downwards
                [[0.0, 0.0, 0.0], [0.1, 0.0, 0.0], [0.0, 0.0, 0.0]],  # cxy: turns across
            ]
        ),
        1,
        (400, 640),
        550.0,
        150.0,
        3.0,
        pixel_variance_px2=0.08,
        relative_error=0.02,
    ),
}

LAM = np.linspace(400.0, 700.0, 31)
U = np.array([0.0, 319.5, 639.0])[:, None, None]
V = np.array([0.0, 199.5, 399.0])[None, :, None]


def test_every_registered_form_has_an_example():
    assert sorted(BLUR_FORMS) == sorted(EXAMPLES)


@pytest.fixture(params=sorted(EXAMPLES))
def blur(request):
    return EXAMPLES[request.param]


def test_spots_broadcast_like_their_arguments_and_stay_under_the_widest(blur):
    spot = blur.spot(U, V, LAM[None, None, :])
    for width in (spot.along, spot.across):
        assert width.shape == (3, 3, LAM.size)
        assert np.all(width > 0)
        assert np.all(width <= blur.sigma(LAM)[None, None, :] + 1e-12)
    assert np.all(np.abs(spot.correlation) < 1)


def test_the_psf_is_the_spot_without_its_pixel_boxes(blur):
    spot = blur.spot(U, V, LAM[None, None, :])
    psf = blur.psf(U, V, LAM[None, None, :], slm_pixel_variance_px2=0.07)
    assert np.all(psf.along <= spot.along) and np.all(psf.along >= 0.2)


def test_the_manifest_entry_builds_the_same_blur(blur):
    again = blur_from_manifest(blur.to_manifest())
    assert type(again) is type(blur) and again.kind == blur.kind
    np.testing.assert_array_equal(again.sigma(LAM), blur.sigma(LAM))
    np.testing.assert_array_equal(again.window_half_width(LAM), blur.window_half_width(LAM))
    assert again.relative_error == blur.relative_error


def test_an_unknown_form_is_refused_naming_the_known_ones():
    with pytest.raises(BundleSchemaError, match="psf_quadratic"):
        blur_from_manifest({"model": "zernike"})


def test_the_profile_conserves_light(blur):
    profile = blur.profile
    # Across: the shares of a row partition sum to one.
    edges = np.arange(-20.0, 21.0) - 0.3
    shares = np.diff(profile.cdf(edges / 1.7))
    assert abs(shares.sum() - 1.0) < 1e-9
    # Along: a bin's light blurred into its neighbours' boxes is all there, inside.
    bins = np.arange(0.0, 41.0)
    spill = profile.box_overlap(bins[:-1], bins[1:], np.full(40, 1.5))
    np.testing.assert_allclose(spill[:, 20].sum(), 1.0, atol=1e-12)
    # A pixel's spot sums to one over whole pixels.
    value = profile.pixel_spot(np.arange(-15, 16) + 0.25, 1.1, 1.2)[0]
    assert abs(value.sum() - 1.0) < 1e-9


def test_the_gaussian_profiles_table_is_its_cdf():
    z = np.linspace(-8.0, 8.0, 4001)
    cubic = GAUSSIAN.cdf_table
    t = (z + 9.0) * 64.0
    i = t.astype(int)
    u = t - i
    table = cubic[i, 0] + u * (cubic[i, 1] + u * (cubic[i, 2] + u * cubic[i, 3]))
    assert np.abs(table - ndtr(z)).max() < 1e-10


def test_the_field_blur_is_never_narrower_than_the_slm_pixels_image():
    """A covariance series that dives below zero (a fit extrapolated past its lasers did,
    on the singlet arm's blue end) is held at the SLM pixel's image on both axes."""
    coeffs = np.zeros((3, 3, 2))
    coeffs[0, 0] = [1.0, 2.0]  # cxx = 1 + 2 t: negative below t = -0.5
    coeffs[1, 0] = [0.5, 2.0]  # cyy = 0.5 + 2 t: negative below t = -0.25
    blur = FieldCovarianceBlur(coeffs, 1, (200, 320), 550.0, 150.0, 3.0, 0.09)
    cxx, cyy, cxy = blur.covariance(100.0, 50.0, [400.0, 550.0])
    np.testing.assert_allclose(cxx, [0.09, 1.0])
    np.testing.assert_allclose(cyy, [0.09, 0.5])
    assert np.all(cxy == 0.0)


def test_the_field_blur_continues_linearly_past_its_measured_band():
    """Past ``band_nm`` the series follows its tangent at the band's end (no bend), in the
    coordinate it is written in, and is the polynomial inside."""
    coeffs = np.zeros((3, 1, 4))
    coeffs[0, 0] = [1.0, 0.5, 0.8, 0.3]  # positive over 380-720 nm in both coordinates
    coeffs[1, 0, 0] = 0.5
    band = (405.0, 670.0)
    for coordinate in ("wavelength", "inverse_square"):
        free = FieldCovarianceBlur(
            coeffs, 0, (200, 320), 550.0, 150.0, 3.0, wavelength_coordinate=coordinate
        )
        held = FieldCovarianceBlur(
            coeffs, 0, (200, 320), 550.0, 150.0, 3.0,
            wavelength_coordinate=coordinate, band_nm=band,
        )  # fmt: skip
        inside = np.linspace(*band, 7)
        np.testing.assert_allclose(
            held.covariance(0, 0, inside)[0], free.covariance(0, 0, inside)[0]
        )
        for beyond in (np.linspace(670.0, 720.0, 6), np.linspace(405.0, 380.0, 6)):
            t = held.wavelength_terms(beyond)[:, 1]  # the coordinate itself
            cxx = held.covariance(0, 0, beyond)[0]
            assert cxx.min() > 0.1  # above the floor, so the line is the series
            slope = np.diff(cxx) / np.diff(t)
            np.testing.assert_allclose(slope, slope[0], rtol=1e-9)
            assert not np.allclose(free.covariance(0, 0, beyond)[0], cxx)


def test_a_field_blur_entry_without_a_wavelength_coordinate_is_a_series_in_wavelength():
    entry = EXAMPLES["field_covariance"].to_manifest()
    del entry["wavelength_coordinate"]
    blur = blur_from_manifest(entry)
    assert blur.wavelength_coordinate == "wavelength" and blur.band_nm is None
    t = (600.0 - 550.0) / 150.0
    np.testing.assert_allclose(blur.wavelength_terms(600.0), [1.0, t, t**2])


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("wavelength_coordinate", "frequency", "must be one of wavelength, inverse_square"),
        ("band_nm", [670.0, 450.0], "0 < low < high"),
        ("band_nm", [450.0], "must hold 2 numbers"),
    ],
)
def test_a_bad_field_blur_band_or_coordinate_is_refused(key, value, message):
    entry = EXAMPLES["field_covariance"].to_manifest() | {key: value}
    with pytest.raises(BundleSchemaError, match=message):
        blur_from_manifest(entry)
