"""Grey-level response: measurement, inverse, and precompensated sinusoids."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sassi_bench.calibrate.grey_response import (
    GreyResponse,
    harmonic_distortion,
    measure_grey_response,
    sinusoid_profile,
)

GAMMA, EPS = 2.2, 1e-3
LEVELS = np.array([*range(0, 256, 16), 255])


def true_response(level):
    return (np.asarray(level, dtype=np.float64) / 255.0) ** GAMMA


def uniform_frames(levels, seed=0, shape=(48, 64), electrons=30000.0):
    """Camera frames (ADU) of uniform SLM patterns: gamma 2.2 with a leak, vignetting, noise."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0 : shape[0], 0 : shape[1]]
    vignette = 1.0 - 0.3 * (((xx - 32) / 40.0) ** 2 + ((yy - 24) / 30.0) ** 2)
    vignette[:6, :] = 0.0  # a strip the SLM does not light
    t = EPS + (1 - EPS) * true_response(levels)[:, None, None]
    e = rng.poisson(electrons * vignette * t) + rng.normal(0.0, 5.0, (len(levels), *shape))
    dark = np.rint(100 + rng.normal(0.0, 5.0, shape) / 0.458)
    return np.clip(np.rint(e / 0.458 + 100), 0, 65535).astype(np.uint16), dark


@pytest.fixture(scope="module")
def measured():
    frames, dark = uniform_frames(LEVELS)
    return measure_grey_response(LEVELS, frames, dark)


def test_measured_response_matches_gamma_curve(measured):
    g = np.arange(256)
    assert np.abs(measured(g) - true_response(g)).max() < 5e-4
    assert measured.gamma == pytest.approx(GAMMA, abs=0.01)
    assert measured.levels.tolist() == LEVELS.tolist()


def test_inverse_round_trip_within_one_level(measured):
    g = np.arange(256)
    recovered = measured.inverse(true_response(g)).astype(int)
    assert recovered.dtype == int and recovered.shape == (256,)
    # Below level ~16 one grey level changes the transmission by < 1e-4, about the
    # measurement noise; there the round trip is judged in transmission instead.
    bright = g >= 16
    assert np.abs(recovered[bright] - g[bright]).max() <= 1
    assert np.abs(true_response(recovered) - true_response(g)).max() < 5e-4


def test_unsorted_levels_and_explicit_mask():
    order = np.random.default_rng(1).permutation(LEVELS.size)
    frames, dark = uniform_frames(LEVELS)
    mask = np.zeros(frames.shape[1:], bool)
    mask[20:30, 20:40] = True
    r = measure_grey_response(LEVELS[order], frames[order], dark, mask=mask)
    assert np.abs(r(np.arange(256)) - true_response(np.arange(256))).max() < 4e-3


def test_saturated_pixels_are_left_out():
    frames, dark = uniform_frames(LEVELS)
    hot = np.clip(frames.astype(np.int64) * 3 - 200, 0, 65535).astype(np.uint16)
    frames[:, 10:48] = hot[:, 10:48]  # most pixels clip at 65535 in the bright frames
    g = np.arange(256)
    r = measure_grey_response(LEVELS, frames, dark)
    assert np.abs(r(g) - true_response(g)).max() < 1e-3
    clipped = measure_grey_response(LEVELS, frames, dark, saturation_level=None)
    assert np.abs(clipped(g) - true_response(g)).max() > 0.05


def test_precompensated_sinusoid_has_low_distortion(measured):
    profile = sinusoid_profile(16, measured)
    assert profile.dtype == np.uint8 and profile.shape == (16,)
    # Mirror samples share a level, so the fringe has no odd (phase-shifting) error.
    assert profile[1:].tolist() == profile[1:][::-1].tolist()
    after = EPS + (1 - EPS) * true_response(profile)
    assert harmonic_distortion(after) < 0.01
    # Without precompensation the same SLM would distort the fringe badly.
    assert harmonic_distortion(true_response(sinusoid_profile(16))) > 0.1


def test_identity_profile_is_rounded_transmission():
    t = np.round(0.5 + 0.5 * np.cos(2 * np.pi * np.arange(12) / 12), 12)
    assert sinusoid_profile(12).tolist() == np.rint(255 * t).astype(int).tolist()
    assert sinusoid_profile(12, GreyResponse.identity()).tolist() == sinusoid_profile(12).tolist()


def test_harmonic_distortion_of_a_known_signal():
    j = np.arange(32)
    signal = np.cos(2 * np.pi * j / 32) + 0.03 * np.cos(2 * np.pi * 3 * j / 32)
    assert harmonic_distortion(signal) == pytest.approx(0.03, rel=1e-9)


def test_non_monotonic_response_is_refused():
    frames, dark = uniform_frames(LEVELS)
    swapped = frames.copy()
    swapped[[5, 9]] = frames[[9, 5]]
    with pytest.raises(ValueError, match=r"grey response: transmission falls .* level 80"):
        measure_grey_response(LEVELS, swapped, dark)


def test_noise_level_dips_are_smoothed_not_refused():
    levels = np.array([0, 128, 130, 255])
    frames = np.ones((4, 8, 8)) * np.array([0.0, 500.0, 499.9, 1000.0])[:, None, None]
    frames += np.random.default_rng(0).normal(0, 2.0, frames.shape)
    r = measure_grey_response(levels, frames, 0.0)
    assert np.all(np.diff(r.response) >= 0)
    assert r.response[1] == pytest.approx(0.5, abs=0.01)


@pytest.mark.parametrize(
    ("levels", "frames_shape", "dark", "match"),
    [
        ([0, 255], (2, 4, 4), 0.0, "too few"),
        ([0, 100, 200], (3, 4, 4), 0.0, "0 and 255"),
        ([0, 100, 100, 255], (4, 4, 4), 0.0, "repeated"),
        ([0, 100, 255], (2, 4, 4), 0.0, "one .* frame per level"),
        ([0, 100, 255], (3, 4, 4), np.zeros((5, 4)), "dark has shape"),
    ],
)
def test_bad_inputs_name_the_problem(levels, frames_shape, dark, match):
    frames = np.ones(frames_shape) * np.linspace(0, 1, frames_shape[0])[:, None, None]
    with pytest.raises(ValueError, match=f"grey response: .*{match}"):
        measure_grey_response(levels, frames, dark)


def test_unlit_frames_are_refused():
    frames = np.zeros((3, 4, 4))
    with pytest.raises(ValueError, match="no usable lit pixels"):
        measure_grey_response([0, 128, 255], frames, 0.0)
    with pytest.raises(ValueError, match="no usable lit pixels"):
        lit = np.ones((3, 4, 4)) * np.array([0.0, 1.0, 2.0])[:, None, None]
        measure_grey_response([0, 128, 255], lit, 0.0, mask=np.zeros((4, 4), bool))


@pytest.mark.parametrize(
    ("levels", "response"),
    [([0, 128], [0.0, 1.0]), ([0, 200, 255], [0.0, 0.6, 0.5]), ([0, 255], [0.1, 1.0])],
)
def test_grey_response_validates(levels, response):
    with pytest.raises(ValueError, match="grey response"):
        GreyResponse(np.array(levels), np.array(response))


@settings(max_examples=60, deadline=None)
@given(
    gamma=st.floats(0.8, 3.0),
    knots=st.lists(st.integers(1, 254), min_size=1, max_size=12, unique=True),
    t=st.lists(st.floats(-0.1, 1.1), min_size=1, max_size=20),
)
def test_inverse_picks_the_nearest_level(gamma, knots, t):
    levels = np.array(sorted({0, 255, *knots}))
    r = GreyResponse(levels, (levels / 255.0) ** gamma)
    table = r(np.arange(256))
    assert np.all(np.diff(table) >= 0)
    assert np.allclose(r(levels), (levels / 255.0) ** gamma, atol=1e-12)
    got = r.inverse(np.array(t))
    best = np.abs(table[None, :] - np.clip(t, 0, 1)[:, None]).min(axis=1)
    assert np.allclose(np.abs(table[got] - np.clip(t, 0, 1)), best, atol=1e-12)


def test_frame_by_frame_measurement_equals_the_whole_stack_formula():
    from scipy.stats import trim_mean

    frames, dark = uniform_frames(LEVELS, seed=4)
    frames[3, 10, 10] = 65535  # a saturated pixel is left out
    order = np.argsort(LEVELS)[::-1]  # any order
    measured = measure_grey_response(LEVELS[order], frames[order], dark)
    signal = frames.astype(np.float64) - dark
    low, span = signal[0], signal[-1] - signal[0]
    use = (span >= 0.5 * np.percentile(span, 99.0)) & ~np.any(frames >= 65535, axis=0)
    ratio = (signal[:, use] - low[use]) / span[use]
    expected = trim_mean(ratio, 0.1, axis=1)
    assert np.all(np.diff(expected) >= 0)  # so the smoothing leaves it as it is
    np.testing.assert_allclose(measured.response, expected, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("scalar_dark", [False, True])
def test_compiled_trimmed_mean_equals_scipy_s_on_a_large_frame(scalar_dark):
    """Above the compiled pass's size (tens of thousands of lit pixels) the response is
    still scipy's trimmed mean of every level's ratios, to rounding."""
    from scipy.stats import trim_mean

    from sassi_bench.calibrate import grey_response as gr

    levels = np.array([0, 64, 128, 192, 255])
    rng = np.random.default_rng(9)
    light = 20000.0 * rng.uniform(0.2, 1.0, (256, 320))  # uneven illumination
    t = EPS + (1 - EPS) * true_response(levels)[:, None, None]
    frames = np.clip(rng.poisson(light * t) / 0.458 + 100, 0, 65535).astype(np.uint16)
    dark = np.rint(100 + rng.normal(0.0, 5.0, light.shape))
    dark = np.float64(100.0) if scalar_dark else dark
    signal = frames.astype(np.float64) - dark
    low, span = signal[0], signal[-1] - signal[0]
    use = span >= 0.5 * np.percentile(span, 99.0)
    assert use.sum() > gr._COMPILED_MIN_PIXELS  # the compiled pass, not the fallback
    ratio = (signal[:, use] - low[use]) / span[use]
    measured = measure_grey_response(levels, frames, dark)
    np.testing.assert_allclose(measured.response, trim_mean(ratio, 0.1, axis=1), rtol=1e-13)
    lit = np.flatnonzero(use)
    dark_lit = dark if scalar_dark else dark.ravel()[lit]
    mean, spread = gr._trimmed_ratio(frames[2], lit, dark_lit, low[use], span[use])
    assert mean == pytest.approx(trim_mean(ratio[2], 0.1), rel=1e-13)
    assert spread == pytest.approx(np.std(ratio[2]), rel=1e-9)
