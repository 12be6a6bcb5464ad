import numpy as np
import pytest

from sassi_bench.calibrate.line_sweep import fit_line_axis, line_centres


def _line_frames(offsets, spacing, width=400, height=120, scale=1.1, tilt=0.01, sigma=1.2):
    yy, xx = np.mgrid[0:height, 0:width].astype(float)
    frames = []
    for offset in offsets:
        frame = np.zeros((height, width))
        for u in range(offset, 300, spacing):
            x = 20 + scale * u + tilt * yy
            frame += 800 * np.exp(-((xx - x) ** 2) / (2 * sigma**2))
        frames.append(frame)
    return frames


def test_line_centres_recover_a_tilted_scaled_sweep():
    offsets = list(range(0, 64, 8))
    centres = line_centres(_line_frames(offsets, 64), offsets, 64, "x", slm_length=300)
    assert centres.skipped_frames == 0
    expected_x = 20 + 1.1 * centres.slm + 0.01 * centres.y
    assert np.abs(centres.x - expected_x).max() < 0.02
    fit = fit_line_axis(centres, (120, 400), degree=2)
    assert fit(np.array([20 + 1.1 * 100]), np.array([0.0]))[0] == pytest.approx(100, abs=0.02)


def test_frames_whose_lines_cannot_be_matched_are_skipped_and_counted():
    offsets = [0, 8]
    frames = _line_frames(offsets, 64)
    frames[1][:, 200:] = 0  # half the lines of the second frame are missing
    centres = line_centres(frames, offsets, 64, "x", slm_length=300)
    assert centres.skipped_frames == 1
