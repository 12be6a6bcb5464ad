"""Gray-code decoding: block centres, bit contrasts, errors."""

import numpy as np
import pytest

from sassi_bench.acquire.patterns import gray_bit_count, render_pattern
from sassi_bench.calibrate.gray_decode import decode_gray


@pytest.mark.parametrize(("length", "block"), [(160, 8), (100, 8), (37, 1), (64, 4), (1920, 8)])
def test_gray_decoding_is_exact_on_noiseless_frames(length, block):
    shape = (2, length)
    bits = range(gray_bit_count(length, block))
    pos = np.stack([render_pattern({"kind": "gray", "axis": "x", "bit": b, "block": block,
                                    "inverse": False}, shape) for b in bits])  # fmt: skip
    neg = 255 - pos
    decoded = decode_gray(pos, neg, block)
    expected = block * (np.arange(length) // block) + (block - 1) / 2
    assert np.array_equal(decoded.coord[0], expected) and np.array_equal(decoded.coord[1], expected)
    assert np.all(decoded.margin == 1.0) and decoded.valid.all()


def test_gray_margin_flags_the_undecidable_bit():
    pos = np.array([[[100.0, 100.0, 60.0]]]).repeat(2, axis=0)
    neg = np.array([[[0.0, 100.0, 40.0]]]).repeat(2, axis=0)
    decoded = decode_gray(pos, neg, block=8, min_margin=0.25)
    assert decoded.margin[0].tolist() == pytest.approx([1.0, 0.0, 0.2])
    assert decoded.second_margin[0].tolist() == pytest.approx([1.0, 0.0, 0.2])
    assert decoded.valid[0].tolist() == [True, False, False]


def test_gray_second_margin_tells_one_weak_bit_from_two():
    # Pixel 0: every bit clear; pixel 1: one bit undecidable (a block boundary);
    # pixel 2: two bits undecidable (ambiguous).
    pos = np.array([[[100.0, 100.0, 50.0]], [[100.0, 90.0, 50.0]], [[0.0, 0.0, 0.0]]])
    neg = np.array([[[0.0, 100.0, 50.0]], [[0.0, 10.0, 50.0]], [[100.0, 100.0, 100.0]]])
    decoded = decode_gray(pos, neg, block=8)
    assert decoded.margin[0].tolist() == pytest.approx([1.0, 0.0, 0.0])
    assert decoded.second_margin[0].tolist() == pytest.approx([1.0, 0.8, 0.0])


def test_gray_dark_is_subtracted_before_the_margin():
    pos, neg = np.full((1, 1, 1), 1100.0), np.full((1, 1, 1), 150.0)
    assert decode_gray(pos, neg, 8).margin.item() == pytest.approx(950 / 1250)
    assert decode_gray(pos, neg, 8, dark=100.0).margin.item() == pytest.approx(950 / 1050)


def test_errors_name_step_cause_and_fix():
    frames = np.zeros((4, 3, 5))
    with pytest.raises(ValueError, match=r"Gray decoding: positive frames .* differ"):
        decode_gray(frames, frames[:3], 8)
    with pytest.raises(ValueError, match="Gray decoding: block 0"):
        decode_gray(frames, frames, 0)
    with pytest.raises(ValueError, match=r"Gray decoding: dark has shape \(3, 4\)"):
        decode_gray(frames, frames, 8, dark=np.zeros((3, 4)))
