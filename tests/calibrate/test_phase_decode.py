"""Phase-shift decoding: pure and shifted sinusoids, unwrapping, errors."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sassi_bench.calibrate.phase_decode import decode_phase, unwrap

PERIOD = 16


@pytest.mark.parametrize(("steps", "period"), [(3, 12), (4, 16), (8, 16), (5, 16), (12, 24)])
def test_phase_decoding_of_pure_sinusoids(steps, period):
    rng = np.random.default_rng(steps)
    truth_coord = rng.uniform(0, period, (6, 7))
    offset = rng.uniform(100, 1000, (6, 7))
    amplitude = rng.uniform(0.1, 1.0, (6, 7)) * offset
    shifts = np.arange(steps) * period // steps  # not equally spaced for 5 steps of 16
    frames = np.stack(
        [offset + amplitude * np.cos(2 * np.pi * (truth_coord - s) / period) for s in shifts]
    )
    fringe = decode_phase(frames.astype(np.float32), period)
    error = (fringe.coord - truth_coord + period / 2) % period - period / 2
    assert np.abs(error).max() < 1e-4
    assert np.all((fringe.coord >= 0) & (fringe.coord < period))
    np.testing.assert_allclose(fringe.modulation, amplitude, rtol=1e-5)
    np.testing.assert_allclose(fringe.offset, offset, rtol=1e-5)


def test_phase_decoding_with_explicit_shifts_and_dark():
    shifts = np.array([0.0, 3.0, 7.5, 11.0])
    p = np.linspace(0, 15.9, 50)[None, :]
    frames = np.stack([110 + 50 * np.cos(2 * np.pi * (p - s) / 16) for s in shifts])
    fringe = decode_phase(frames, 16, shifts=shifts, dark=10.0)
    # Frames are converted to float32 one by one: ~1e-7 relative precision.
    np.testing.assert_allclose((fringe.coord - p + 8) % 16 - 8, 0.0, atol=1e-5)
    np.testing.assert_allclose(fringe.offset, 100.0, rtol=1e-6)


@settings(max_examples=200, deadline=None)
@given(
    true_coord=st.floats(0.0, 400.0),
    coarse_error=st.floats(-7.9, 7.9),
    noise=st.floats(-0.05, 0.05),
)
def test_unwrap_picks_the_right_period_even_at_period_boundaries(true_coord, coarse_error, noise):
    measured = true_coord + noise
    phase = np.mod(measured, PERIOD)
    got = unwrap(phase, true_coord + coarse_error, PERIOD)
    assert got == pytest.approx(measured, abs=1e-9)


def test_unwrap_at_exact_boundaries():
    phase = np.array([0.0, 15.999, 0.001, 15.999, 0.001])
    coarse = np.array([16.0, 15.5, 16.5, 32.0 - 7.0, 7.9])
    assert unwrap(phase, coarse, 16).tolist() == pytest.approx(
        [16.0, 15.999, 16.001, 31.999, 0.001]
    )


def test_errors_name_step_cause_and_fix():
    frames = np.zeros((4, 3, 5))
    with pytest.raises(ValueError, match=r"phase decoding: .*\(2, 3, 5\).*Fix: pass at least 3"):
        decode_phase(frames[:2], 16)
    with pytest.raises(ValueError, match=r"phase decoding: phase shifts .* do not span"):
        decode_phase(frames, 16, shifts=[0, 0, 0, 0])
    with pytest.raises(
        ValueError, match=r"phase decoding: shifts has shape \(3,\), expected \(4,\) for 4"
    ):
        decode_phase(frames, 16, shifts=[0, 4, 8])
