"""The response step's stopping rule, its record, and the scan order it refines."""

import numpy as np

from sassi_bench.acquire.scan_plans import refining_scan_plan, scan_plan
from sassi_bench.reduce.response_budget import (
    ResponseBatch,
    ResponseFrameRecord,
    decide_response_frames,
    response_frame_settings,
    response_sigma,
)
from sassi_bench.spectra.deblur import MeanSpectrum


def test_the_thinned_scan_suffices_on_sim_and_a_tighter_tolerance_doubles_it():
    # sim: the response at +-0.42 % (worst bin, the blue) after every 25th offset's 20 frames
    assert decide_response_frames(20, 0.0042, 0.005, 80).outcome == "tolerance met"
    assert decide_response_frames(20, 0.0042, 0.003, 80).next_frames == 40  # 20 * 1.96
    assert decide_response_frames(80, 0.0042, 0.003, 80).outcome == "budget spent"


def test_settings_default_and_never_budget_below_the_thinned_scan():
    assert response_frame_settings({}, 20) == (20, 80, 0.005)
    assert response_frame_settings({"max_frames": 10, "sigma_max": 0.01}, 20) == (20, 20, 0.01)


def test_the_stated_sigma_is_the_worst_band_bin_relative_to_its_light():
    white = MeanSpectrum(
        np.array([1.0, 4.0, 2.0, 1.0]), np.array([9.0, 0.04, 0.01, 9.0]), 50, None, 1
    )
    assert response_sigma(white) == 0.01  # guard bins are not the response's


def test_a_spent_budget_says_how_many_frames_would_do():
    batches = (
        ResponseBatch(20, 0.012, 80, "more frames"),
        ResponseBatch(80, 0.006, None, "budget spent"),
    )
    record = ResponseFrameRecord(batches, 0.005, 80, 25)
    assert "take about 116" in record.advice()  # 80 * 1.2**2 = 115.2
    assert "80 pinhole frames of the white (20, then 80)" in record.note()
    assert record.to_json()["sigma_relative"] == 0.006


def test_every_prefix_of_the_refining_plan_is_a_thinned_scan():
    plan = refining_scan_plan(scan_plan((400, 640), "halogen", 0.1, (100, 5)), 25, 80)
    assert plan.steps[0].tags["role"] == "closed" and len(plan.steps) == 81
    offsets = [(s.tags["ox"], s.tags["oy"]) for s in plan.steps[1:]]
    assert set(offsets[:20]) == {(ox, oy) for oy in range(5) for ox in (0, 25, 50, 75)}
    assert {ox % 25 for ox, _ in offsets[20:40]} == {12}  # then halfway between
    assert len(set(offsets)) == 80
    assert [s.tags["frame"] for s in plan.steps[1:]] == list(range(80))
