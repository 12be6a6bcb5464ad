"""The lamp step's stopping rule on synthetic measurements (``reduce/lamp_budget.py``)."""

from __future__ import annotations

import math

import pytest

from sassi_bench.reduce.lamp_budget import (
    DEFAULT_MAX_FRAMES,
    LampBatch,
    LampFrameRecord,
    decide_lamp_frames,
    lamp_frame_settings,
)


def photon_limited(sigma_at_one: float):
    """A laser's 1-sigma that falls as one over the square root of the frames."""
    return lambda frames: {670.0: sigma_at_one / math.sqrt(frames), 520.0: 0.05}


def run_rule(sigma_of, first: int, budget: int, tolerance: float) -> list[LampBatch]:
    """The decisions the lamp step makes when each batch measures ``sigma_of(frames)``."""
    frames, batches = first, []
    while True:
        batch = decide_lamp_frames(frames, sigma_of(frames), tolerance, budget)
        batches.append(batch)
        if batch.next_frames is None:
            return batches
        assert batch.next_frames > frames  # never the same frames twice
        frames = batch.next_frames


def test_it_stops_when_every_laser_meets_the_tolerance():
    batch = decide_lamp_frames(4, {520.0: 0.05, 670.0: 0.5}, 0.5, 16)
    assert (batch.outcome, batch.next_frames) == ("tolerance met", None)


def test_it_continues_to_the_frames_a_photon_limited_laser_needs():
    # 0.8 nm at 4 frames: 4 * (0.8 / 0.5)**2 = 10.24, so 11 frames.
    batch = decide_lamp_frames(4, {520.0: 0.05, 670.0: 0.8}, 0.5, 16)
    assert (batch.outcome, batch.next_frames) == ("more frames", 11)
    # Barely above the tolerance: one more frame, not the same frames again.
    assert decide_lamp_frames(4, {670.0: 0.5001}, 0.5, 16).next_frames == 5
    # A need beyond the budget takes the budget.
    assert decide_lamp_frames(4, {670.0: 2.0}, 0.5, 16).next_frames == 16


def test_a_photon_limited_laser_is_met_in_one_more_batch():
    batches = run_rule(photon_limited(1.6), first=4, budget=16, tolerance=0.5)
    # 0.8 nm at 4 frames, 0.48 nm at the 11 it asks for.
    assert [b.frames for b in batches] == [4, 11]
    assert batches[-1].outcome == "tolerance met"
    assert batches[-1].sigma_nm[670.0] == pytest.approx(1.6 / math.sqrt(11))


def test_it_stops_at_the_budget_and_says_what_would_meet_the_tolerance():
    batches = run_rule(photon_limited(3.0), first=4, budget=16, tolerance=0.5)
    assert [b.frames for b in batches] == [4, 16]
    assert batches[-1].outcome == "budget spent"
    record = LampFrameRecord(tuple(batches), 0.5, 16, {"lamp:Ne": 0.2}, 10.0)
    assert record.frames == 16 and record.short_of == {670.0: pytest.approx(0.75)}
    # 16 * (0.75 / 0.5)**2 = 36 frames.
    advice = record.advice()
    assert "laser 670 nm at +-0.75 nm after 16 lamp frames" in advice
    assert "take about 36 lamp frames per lamp" in advice and "lamps.max_frames to 36" in advice
    assert "longer exposure" not in advice  # the lamp was not at the longest exposure
    as_json = record.to_json()
    assert as_json["outcome"] == "budget spent" and as_json["frames_per_lamp"] == 16
    assert [b["frames"] for b in as_json["batches"]] == [4, 16]
    assert as_json["advice"] == advice


def test_a_lamp_at_its_longest_exposure_is_told_to_expose_longer():
    last = LampBatch(16, {670.0: 0.6}, None, "budget spent")
    advice = LampFrameRecord((last,), 0.5, 16, {"lamp:Ne": 10.0}, 10.0).advice()
    assert "lamp:Ne ran at the longest allowed (10 s); raise lamps.max_s" in advice


def test_a_line_frames_cannot_pin_names_a_lamp_or_a_prism():
    # 3 nm after 16 frames: 576 frames, 36 times the budget: the lines blend or are missing.
    last = LampBatch(16, {670.0: 3.0}, None, "budget spent")
    advice = LampFrameRecord((last,), 0.5, 16, {"lamp:Ne": 0.2}, 10.0).advice()
    assert "more frames will not do" in advice
    assert "a lamp with isolated lines there" in advice and "prism" in advice


def test_a_met_tolerance_needs_no_advice():
    met = LampBatch(4, {670.0: 0.3}, None, "tolerance met")
    assert LampFrameRecord((met,), 0.5, 16, {}, 10.0).advice() is None


def test_the_settings_default_the_budget_and_keep_the_first_batch_within_it():
    assert lamp_frame_settings({"lamps": {"frames": 4}}) == (4, DEFAULT_MAX_FRAMES, 0.5)
    tolerances = {"laser_wavelength_sigma_nm": 0.2}
    proc = {"lamps": {"frames": 6, "max_frames": 3}, "tolerances": tolerances}
    assert lamp_frame_settings(proc) == (3, 3, 0.2)
    with pytest.raises(ValueError, match="must be positive"):
        decide_lamp_frames(0, {670.0: 1.0}, 0.5, 16)
