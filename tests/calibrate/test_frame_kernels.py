"""The compiled frame loops against the numpy expressions they replace, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.lib.stride_tricks import sliding_window_view

from sassi_bench.calibrate import _frame_kernels as k

RNG = np.random.default_rng(7)
SHAPE = (37, 53)


def _frames(count: int) -> np.ndarray:
    return RNG.integers(0, 4000, (count, *SHAPE)).astype(np.uint16)


@pytest.mark.parametrize("dark_map", [True, False])
def test_gray_pair_is_numpy_s_running_decode(dark_map):
    pos, neg = _frames(2)
    neg[0, :5] = pos[0, :5]  # ties: zero contrast, bit clear
    pos[1, :3], neg[1, :3] = 0, 0  # no light: contrast 0
    pos[2, 2] = 65535
    dark = RNG.uniform(90, 110, SHAPE).astype(np.float32) if dark_map else np.float32(100.0)
    smallest = RNG.uniform(0, 1, SHAPE).astype(np.float32)
    second = np.maximum(smallest, RNG.uniform(0, 1, SHAPE).astype(np.float32))
    word, clipped = np.full(SHAPE, 5, np.int32), np.zeros(SHAPE, bool)
    expected = {}
    on = pos.astype(np.float32) - dark
    off = neg.astype(np.float32) - dark
    total = on + off
    contrast = np.abs(on - off) / np.where(total > 0, total, np.float32(np.inf))
    expected["second"] = np.minimum(second, np.maximum(smallest, contrast))
    expected["smallest"] = np.minimum(smallest, contrast)
    expected["word"] = np.where(on > off, word | 8, word)
    expected["clipped"] = (pos >= 65535) | (neg >= 65535)
    dark_arr = np.asarray(dark, np.float32).reshape(SHAPE if dark_map else (1, 1))
    k.gray_pair(pos, neg, dark_arr, dark_map, np.int32(8), word, smallest, second, clipped, 65535.0)
    for name, value in (("second", second), ("smallest", smallest), ("word", word),
                        ("clipped", clipped)):  # fmt: skip
        assert np.array_equal(value, expected[name]), name


def test_gray_index_undoes_the_gray_code():
    index = RNG.integers(0, 256, SHAPE)
    word = (index ^ (index >> 1)).astype(np.int32)
    assert np.array_equal(k.gray_index(word, 8), index)


def _numpy_phase(frames, dark, solver):
    coef = np.zeros((3, *frames.shape[1:]))
    for s, raw in enumerate(frames):
        frame = raw.astype(np.float32) - dark
        for j in range(3):
            coef[j] += solver[j, s] * frame
    return coef


def test_phase_passes_are_numpy_s_fit():
    frames = _frames(6)
    dark = RNG.uniform(90, 110, SHAPE).astype(np.float32)
    solver = RNG.normal(size=(3, 6))
    coef = _numpy_phase(frames, dark, solver)
    usable = np.empty(SHAPE, bool)
    k.phase_usable(frames, dark, True, solver, usable)
    assert np.array_equal(usable, (coef[0] > 0) & (np.hypot(coef[1], coef[2]) > 0.2 * coef[0]))
    skip = RNG.random(SHAPE) < 0.3
    offset, coord, modulation = (np.empty(SHAPE) for _ in range(3))
    k.phase_fit(frames, dark, True, solver, 16.0, skip, True, offset, coord, modulation)
    expected = np.mod(np.arctan2(coef[2], coef[1]) * (16.0 / (2.0 * np.pi)), 16.0)
    expected[expected >= 16.0] = 0.0
    assert np.array_equal(offset, coef[0])
    assert np.array_equal(modulation, np.hypot(coef[1], coef[2]))
    np.testing.assert_allclose(coord[~skip], expected[~skip], rtol=0, atol=1e-12)
    assert np.all(coord[skip] == 0.0)


def test_axis_reasons_are_the_tests_in_order():
    shape = SHAPE
    is_dark, clipped = RNG.random(shape) < 0.1, RNG.random(shape) < 0.1
    modulation, offset = RNG.uniform(0, 1, shape), RNG.uniform(-0.2, 1, shape)
    second = RNG.uniform(0, 1, shape).astype(np.float32)
    phase, index = RNG.uniform(0, 16, shape), RNG.integers(0, 100, shape)
    coord, coarse, depth = (np.empty(shape) for _ in range(3))
    reason = np.empty(shape, np.uint8)
    k.axis_reasons(is_dark, clipped, modulation, offset, second, phase, index, 8, 16.0, 0.25,
                   0.2, 6.0, coord, coarse, depth, reason)  # fmt: skip
    centre = 8 * index + 3.5
    unwrapped = phase + 16.0 * np.rint((centre - phase) / 16.0)
    d = np.where(offset > 0, modulation / np.where(offset > 0, offset, 1.0), 0.0)
    flags = [is_dark, clipped, ~(d >= 0.25), second < 0.2, np.abs(unwrapped - centre) > 6.0]
    expected = np.zeros(shape, np.uint8)
    for code in range(len(flags), 0, -1):
        expected[flags[code - 1]] = code
    assert np.array_equal(reason, expected)
    assert np.array_equal(coord, unwrapped) and np.array_equal(coarse, centre)
    assert np.array_equal(depth, d)
    low, high = 20.0, 700.0
    k.edge_reasons(coord, reason, low, high)
    edge = (expected == 0) & ((unwrapped < low) | (unwrapped > high))
    assert np.array_equal(reason, np.where(edge, 6, expected))


def test_window_outliers_are_the_sorted_windows_medians():
    values = RNG.normal(0.0, 0.3, (60, 80)).astype(np.float32)
    values[RNG.random(values.shape) < 0.05] += 3.0  # a few wrong Gray words
    values[::7, ::5] = 0.25  # ties
    reason = np.where(RNG.random(values.shape) < 0.3, 1, 0).astype(np.uint8)
    padded = np.pad(np.where(reason == 0, values, np.inf), 2, constant_values=np.inf)
    expected = reason.copy()
    ordered = np.sort(sliding_window_view(padded, (5, 5)).reshape(*values.shape, 25), axis=-1)
    count = np.sum(np.isfinite(ordered), axis=-1)
    safe = np.maximum(count, 1)
    lo = np.take_along_axis(ordered, ((safe - 1) // 2)[..., None], -1)[..., 0]
    hi = np.take_along_axis(ordered, (safe // 2)[..., None], -1)[..., 0]
    median = np.float32(0.5) * (lo + hi)
    jump = np.abs(values - median)
    expected[(reason == 0) & (count - 1 >= 6) & (jump > 0.5)] = 7
    found = k.window_outliers(padded, reason, 5, 0.5, 6)
    assert np.array_equal(reason, expected) and found == int((expected == 7).sum()) > 0


def test_frame_moments_and_sums_are_numpy_s():
    frames = _frames(4)
    mean, variance = np.empty(SHAPE), np.empty(SHAPE)
    k.frame_moments(frames, mean, variance)
    stack = frames.astype(np.float64)
    assert np.array_equal(mean, stack.mean(0))
    np.testing.assert_allclose(variance, stack.var(0, ddof=1), rtol=1e-13)
    total = np.zeros(SHAPE, np.float32)
    for frame in frames:
        k.accumulate(frame, total)
    assert np.array_equal(total, frames.astype(np.float32).sum(0))


def _ratio_inputs(values: np.ndarray, seed: int = 0):
    """Frame, lit indices, dark, low and span whose ratios are ``values`` up to rounding."""
    rng = np.random.default_rng(seed)
    n = values.size
    size = 2 * n + 7
    lit = np.sort(rng.choice(size, n, replace=False))
    span = rng.uniform(2000.0, 3000.0, n)
    low = rng.uniform(10.0, 20.0, n)
    dark = rng.uniform(90.0, 110.0, n)
    frame = np.zeros(size, np.float64)
    frame[lit] = values * span + dark + low
    ratio = (frame[lit] - dark - low) / span
    return frame, lit, dark, low, span, ratio


@pytest.mark.parametrize(
    "kind", ["normal", "heavy tails", "ties at the cuts", "spatial gradient", "uint16"]
)
@pytest.mark.parametrize("n", [3_001, 60_000])
def test_trimmed_ratio_mean_is_scipy_s_trim_mean(kind, n):
    from scipy.stats import trim_mean

    rng = np.random.default_rng(n)
    values = {
        "normal": lambda: rng.normal(0.5, 0.05, n),
        "heavy tails": lambda: rng.standard_cauchy(n),
        "ties at the cuts": lambda: rng.integers(0, 7, n) / 6.0,
        "spatial gradient": lambda: np.linspace(0.2, 0.9, n) + rng.normal(0, 0.01, n),
        "uint16": lambda: rng.normal(0.5, 0.05, n),
    }[kind]()
    frame, lit, dark, low, span, ratio = _ratio_inputs(values)
    if kind == "uint16":
        frame = np.rint(frame).astype(np.uint16)
        ratio = (frame[lit] - dark - low) / span
    lowercut, step = int(0.1 * n), 16 if n < 10_000 else 128  # a sample of at least ~190
    mean, std, ok = k.trimmed_ratio_mean(frame, lit, dark, low, span, lowercut, step, 6.0)
    assert ok
    np.testing.assert_allclose(mean, trim_mean(ratio, 0.1), rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(std, np.std(ratio), rtol=1e-9)


def test_trimmed_ratio_mean_uses_one_dark_level():
    from scipy.stats import trim_mean

    frame, lit, _, low, span, _ = _ratio_inputs(np.random.default_rng(3).normal(0.4, 0.1, 9000))
    dark = np.array([100.0])
    ratio = (frame[lit] - 100.0 - low) / span
    mean, _, ok = k.trimmed_ratio_mean(frame, lit, dark, low, span, 900, 128, 6.0)
    assert ok
    np.testing.assert_allclose(mean, trim_mean(ratio, 0.1), rtol=1e-13)


@pytest.mark.parametrize("case", ["all equal", "not finite", "a misleading sample"])
def test_trimmed_ratio_mean_declines_what_it_cannot_place(case):
    rng = np.random.default_rng(5)
    values = np.full(5000, 0.5) if case == "all equal" else rng.normal(0.5, 0.05, 5000)
    if case == "not finite":
        values[17] = np.nan
    if case == "a misleading sample":  # every sampled ratio far below the others
        values[::128] = rng.uniform(0.1, 0.11, values[::128].size)
    frame, lit, dark, low, span, _ = _ratio_inputs(values)
    assert not k.trimmed_ratio_mean(frame, lit, dark, low, span, 500, 128, 6.0)[2]
