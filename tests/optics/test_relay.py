"""The ray trace of the SLM -> prism -> spectral camera relay, against physics."""

import numpy as np
import pytest

from sassi_bench.optics.glass import get_glass, refractive_index
from sassi_bench.optics.prism import deviation_deg
from sassi_bench.optics.relay import SpectralRelay

#: The sim rig's relay and prism (procedures/rigs/sim.yaml).
SIM = {
    "scale": 1.08,
    "rotation_deg": 0.3,
    "offset_px": (14.0, 3.0),
    "distortion_k1": 0.005,
    "glass": get_glass("N-BK7"),
    "apex_deg": 30,
    "spread_px": 68,
    "smile_px": 0.8,
    "reference_nm": 550,
}


def make_relay(**changes):
    return SpectralRelay((400, 640), (512, 800), **{**SIM, **changes})


@pytest.fixture(scope="module")
def relay():
    return make_relay()


FIELD = [(0, 0), (639, 0), (0, 399), (639, 399), (319.5, 199.5), (100, 300)]


def test_spread_at_field_centre_equals_spread_px(relay):
    x, _ = relay.forward(319.5, 199.5, np.array([400.0, 700.0]))
    assert x[1] - x[0] == pytest.approx(SIM["spread_px"], abs=1e-6)


@pytest.mark.parametrize(("u", "v"), FIELD)
def test_dispersion_is_monotonic_everywhere(relay, u, v):
    lam = np.linspace(390, 720, 331)
    x, _ = relay.forward(u, v, lam)
    assert np.all(np.diff(x) > 0)
    # Dispersion is strongest in the blue: ~2 nm/px at 400 nm, ~10 nm/px at 700 nm.
    slope = np.gradient(x, lam)
    assert 1.5 < 1 / slope[lam == 400][0] < 2.6
    assert 7.5 < 1 / slope[lam == 700][0] < 12.5


def test_dispersion_follows_the_glass_not_a_polynomial(relay):
    lam = np.linspace(400, 700, 61)
    x, _ = relay.forward(0, 0, lam)
    n = refractive_index("N-BK7", lam)
    # A quadratic in the refractive index fits well (the calibration's model) ...
    resid_n = x - np.polyval(np.polyfit(n, x, 2), n)
    assert np.abs(resid_n).max() < 0.05
    # ... a quadratic in wavelength does not: the truth is physics, not a polynomial.
    resid_lam = x - np.polyval(np.polyfit(lam, x, 2), lam)
    assert np.abs(resid_lam).max() > 0.5


def test_forward_is_vectorised_with_broadcasting(relay):
    u = np.arange(6.0).reshape(2, 3)
    x, y = relay.forward(u, 10.0, 550.0)
    assert x.shape == y.shape == (2, 3)
    x, y = relay.forward(u[..., None], 10.0, np.array([450.0, 650.0]))
    assert x.shape == (2, 3, 2)


def test_inverse_undoes_forward(relay):
    rng = np.random.default_rng(0)
    u, v = rng.uniform(0, 639, 200), rng.uniform(0, 399, 200)
    x, y = relay.forward(u, v, 480.0)
    ui, vi = relay.inverse(x, y, 480.0)
    assert np.allclose(ui, u, atol=1e-6) and np.allclose(vi, v, atol=1e-6)


def test_relay_scale_and_rotation():
    relay = make_relay(rotation_deg=2.0, distortion_k1=0.0)
    x0, y0 = relay.forward(319.5, 199.5, 550.0)
    x1, y1 = relay.forward(329.5, 199.5, 550.0)  # 10 SLM px along a row
    assert np.hypot(x1 - x0, y1 - y0) / 10 == pytest.approx(SIM["scale"], rel=0.01)
    assert np.rad2deg(np.arctan2(y1 - y0, x1 - x0)) == pytest.approx(2.0, abs=0.05)


def test_distortion_moves_the_corners_not_the_centre():
    plain = make_relay(distortion_k1=0.0)
    barrel = make_relay(distortion_k1=0.01)
    xc0, _ = plain.forward(319.5, 199.5, 550.0)
    xc1, _ = barrel.forward(319.5, 199.5, 550.0)
    assert xc1 == pytest.approx(xc0, abs=0.05)
    x0, y0 = plain.forward(0, 0, 550.0)
    x1, y1 = barrel.forward(0, 0, 550.0)
    assert np.hypot(x1 - x0, y1 - y0) > 1.0


def test_streak_ends_differ_by_smile_px_from_the_prism_roll():
    level = make_relay(smile_px=0.0)
    rolled = make_relay(smile_px=1.5)
    _, y_level = level.forward(319.5, 199.5, np.array([400.0, 700.0]))
    _, y_rolled = rolled.forward(319.5, 199.5, np.array([400.0, 700.0]))
    assert y_level[1] - y_level[0] == pytest.approx(0.0, abs=1e-6)
    assert y_rolled[1] - y_rolled[0] == pytest.approx(1.5, abs=1e-6)
    assert np.rad2deg(rolled.roll_rad) == pytest.approx(np.rad2deg(np.arctan(1.5 / 68)), rel=0.05)


def test_row_shift_is_close_to_but_not_exactly_quadratic_in_wavelength(relay):
    lasers = np.array([450.0, 520.0, 532.0, 635.0, 670.0])
    lam = np.linspace(400, 700, 61)
    for u, v in FIELD:
        _, y_lasers = relay.forward(u, v, lasers)
        _, y = relay.forward(u, v, lam)
        err = np.polyval(np.polyfit(lasers, y_lasers, 2), lam) - y
        assert 1e-4 < np.abs(err).max() < 0.1


def test_skew_rays_curve_spectral_lines():
    # The classic prism smile: a spectral line's x depends on the field row.
    relay = make_relay(rotation_deg=0.0, smile_px=0.0)
    x_mid, _ = relay.forward(319.5, 199.5, 550.0)
    x_top, _ = relay.forward(319.5, 0.0, 550.0)
    x_bottom, _ = relay.forward(319.5, 399.0, 550.0)
    assert x_top - x_mid == pytest.approx(x_bottom - x_mid, rel=0.05)
    assert abs(x_top - x_mid) > 0.1


@pytest.mark.parametrize("du", [0.0, -300.0, 250.0])
def test_in_plane_rays_follow_the_textbook_prism_deviation(du):
    """Independent of the 3-D vector trace: Snell's law at both faces in the plane of
    dispersion (the textbook deviation formula) for SLM pixels on the central row."""
    relay = make_relay(rotation_deg=0.0, distortion_k1=0.0, smile_px=0.0)
    lam = np.array([400.0, 450.0, 532.0, 635.0, 700.0])
    n, n_ref = refractive_index("N-BK7", lam), refractive_index("N-BK7", 550.0)
    # The collimated beam of pixel u leaves the collimator at theta and meets the first
    # face at incidence + theta; the camera axis is the deviated 550 nm ray of the centre.
    theta = np.arctan(du / relay.f1)
    out = theta - np.deg2rad(deviation_deg(n, 30.0, relay.incidence_deg + np.rad2deg(theta)))
    axis = -np.deg2rad(deviation_deg(n_ref, 30.0, relay.incidence_deg))
    x, y = relay.forward(319.5 + du, 199.5, lam)
    x_axis, y_axis = relay.forward(319.5, 199.5, 550.0)
    np.testing.assert_allclose(x - x_axis, relay.f2 * np.tan(out - axis), atol=1e-6)
    np.testing.assert_allclose(y, y_axis, atol=1e-9)  # in-plane rays stay on the row


def test_another_prism_keeps_the_alignment_and_aims_the_camera_at_its_light(relay):
    steeper = relay.with_prism(relay.glass, 30.4)
    assert (steeper.f2, steeper.roll_rad, steeper.incidence_deg) == (
        relay.f2,
        relay.roll_rad,
        relay.incidence_deg,
    )
    # The camera follows the new prism's reference ray: it still lands on the optical centre.
    x, y = steeper.forward(*relay.slm_centre, 550.0)
    assert (x, y) == pytest.approx(relay.optical_centre, abs=1e-9)
    # ... but the steeper prism disperses more than the described spread.
    x, _ = steeper.forward(319.5, 199.5, np.array([400.0, 700.0]))
    assert x[1] - x[0] > SIM["spread_px"] + 0.5
    # The aligned relay is unchanged.
    x, _ = relay.forward(319.5, 199.5, np.array([400.0, 700.0]))
    assert x[1] - x[0] == pytest.approx(SIM["spread_px"], abs=1e-6)


def test_the_same_prism_put_back_changes_nothing(relay):
    # The camera is re-aimed with the final roll (the alignment's last step aimed it with
    # the roll before): a change far below a micro-pixel.
    again = relay.with_prism(relay.glass, relay.apex_deg)
    u, v = np.meshgrid(np.linspace(0, 639, 5), np.linspace(0, 399, 4))
    lam = np.linspace(400, 700, 7)
    np.testing.assert_allclose(
        again.forward(u[..., None], v[..., None], lam),
        relay.forward(u[..., None], v[..., None], lam),
        rtol=0,
        atol=1e-6,
    )


def test_the_compiled_trace_is_the_numpy_trace(relay, monkeypatch):
    """Many rays go through the compiled trace, a few through numpy: the same rays agree
    to 1e-9 px (rounding), over the field and beyond the band, and both give NaN where a
    ray is totally internally reflected."""
    from sassi_bench.optics import relay as relay_module

    rng = np.random.default_rng(3)
    u = rng.uniform(-3000, 3640, 3000)  # up to 30 degrees off axis
    v = rng.uniform(-3000, 3400, 3000)
    lam = rng.uniform(350, 800, 3000)
    steep = relay.with_prism(relay.glass, 45.0)  # reflects a quarter of these rays totally
    for traced in (relay, steep):
        monkeypatch.setattr(relay_module, "_COMPILED_MIN_RAYS", 10**9)
        x0, y0 = traced.forward(u, v, lam)
        monkeypatch.setattr(relay_module, "_COMPILED_MIN_RAYS", 1)
        x1, y1 = traced.forward(u, v, lam)
        np.testing.assert_array_equal(np.isnan(x1), np.isnan(x0))
        np.testing.assert_allclose(x1, x0, rtol=0, atol=1e-9, equal_nan=True)
        np.testing.assert_allclose(y1, y0, rtol=0, atol=1e-9, equal_nan=True)
    assert np.isnan(x1).any() and not np.isnan(x1).all()


def test_forward_grid_is_forward_of_every_pair(relay, monkeypatch):
    from sassi_bench.optics import relay as relay_module

    monkeypatch.setattr(relay_module, "_COMPILED_MIN_RAYS", 1)
    u, v = np.array([0.0, 319.5, 639.0]), np.array([0.0, 199.5, 399.0])
    lam = np.linspace(390, 720, 166)
    x, y = relay.forward_grid(u, v, lam)
    x0, y0 = relay.forward(u[:, None], v[:, None], lam[None, :])
    assert x.shape == (3, 166)
    np.testing.assert_array_equal(x, x0)  # the compiled trace, ray for ray
    np.testing.assert_array_equal(y, y0)
