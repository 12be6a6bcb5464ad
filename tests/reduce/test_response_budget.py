"""The response step's stopping rule, its record, and the scan order it refines."""

import numpy as np
import pytest

from sassi_bench.acquire.scan_plans import refining_scan_plan, scan_plan
from sassi_bench.reduce.response_budget import (
    DEFAULT_DE00_TOLERANCE,
    ResponseBatch,
    ResponseFrameRecord,
    ResponseSettings,
    decide_response_frames,
    response_de00_sigma,
    response_frame_settings,
    response_sigma,
)
from sassi_bench.reduce.response_colour import ColourChart
from sassi_bench.spectra.deblur import MeanSpectrum
from sassi_bench.validate.colorimetry import (
    delta_e2000,
    reflectance_to_lab,
    reflectance_to_xyz,
    white_chromaticity,
)
from sassi_bench.validate.reference import reference_chart


def test_the_colour_error_decides_and_the_worst_bin_only_when_asked():
    colour_only = ResponseSettings(20, 80, 0.05)
    # fam10's case: the deep blue's bin at +-1 % while the colour it causes is within
    # tolerance: stop.
    assert decide_response_frames(20, 0.0099, 0.04, colour_only).outcome == "tolerance met"
    both = ResponseSettings(20, 80, 0.05, sigma_max=0.005)
    assert decide_response_frames(20, 0.0099, 0.04, both).next_frames == 79  # 20 * 1.98**2
    assert decide_response_frames(20, 0.004, 0.07, colour_only).next_frames == 40  # 20 * 1.4**2
    assert decide_response_frames(80, 0.004, 0.07, colour_only).outcome == "budget spent"


def test_settings_default_and_never_budget_below_the_thinned_scan():
    assert response_frame_settings({}, 20) == ResponseSettings(20, 80, DEFAULT_DE00_TOLERANCE)
    # An older procedure's sigma_max still holds, beside the colour tolerance.
    old = response_frame_settings({"max_frames": 10, "sigma_max": 0.01}, 20)
    assert old == ResponseSettings(20, 20, DEFAULT_DE00_TOLERANCE, 0.01)
    new = response_frame_settings({"de00_sigma_max": 0.1, "sigma_max": None}, 20)
    assert (new.de00_max, new.sigma_max) == (0.1, None)


def test_the_stated_sigma_is_the_worst_band_bin_relative_to_its_light():
    white = MeanSpectrum(
        np.array([1.0, 4.0, 2.0, 1.0]), np.array([9.0, 0.04, 0.01, 9.0]), 50, None, 1
    )
    assert response_sigma(white) == 0.01  # guard bins are not the response's


def test_the_colour_sigma_is_a_gains_colour_error_for_a_common_error_and_halves_with_it():
    edges = np.linspace(400.0, 700.0, 31)
    centres = (edges[1:] + edges[:-1]) / 2
    spectrum = np.r_[0.0, np.linspace(1.0, 3.0, 30), 0.0]
    std = 0.002 * spectrum
    common = MeanSpectrum(spectrum, std, 100, None, 1, np.outer(std, std))
    quarter = MeanSpectrum(spectrum, std / 2, 100, None, 1, np.outer(std, std) / 4)
    refl = reference_chart().bin_average(edges)
    chart = ColourChart(
        refl, reflectance_to_xyz(centres, np.eye(centres.size)), white_chromaticity()
    )
    sigma = response_de00_sigma(common, chart)
    # Every bin's error the same: a gain of the response, whose colour error is exact.
    gain = delta_e2000(reflectance_to_lab(centres, refl), reflectance_to_lab(centres, 1.002 * refl))
    assert sigma == pytest.approx(float(np.mean(gain)), rel=0.01)
    assert response_de00_sigma(quarter, chart) == pytest.approx(sigma / 2, rel=1e-6)


def test_a_spent_budget_says_how_many_frames_would_do():
    batches = (
        ResponseBatch(20, 0.012, 0.12, 80, "more frames"),
        ResponseBatch(80, 0.006, 0.06, None, "budget spent"),
    )
    record = ResponseFrameRecord(batches, ResponseSettings(20, 80, 0.05), 25)
    assert "take about 116" in record.advice()  # 80 * 1.2**2 = 115.2
    assert "80 pinhole frames of the white (20, then 80)" in record.note()
    taken = record.to_json()
    assert (taken["de00_sigma"], taken["sigma_relative"]) == (0.06, 0.006)
    assert taken["tolerance_relative"] is None and taken["batches"][0]["de00_sigma"] == 0.12


def test_a_colour_sigma_that_does_not_fall_stops_short_of_the_budget():
    settings = ResponseSettings(20, 80, 0.05)
    first = decide_response_frames(20, 0.009, 0.07, settings)
    assert first.next_frames == 40  # 20 * (0.07 / 0.05)**2 = 39.2
    second = decide_response_frames(40, 0.0088, 0.068, settings, [first])
    assert second.outcome == "more frames"
    third = decide_response_frames(second.next_frames, 0.0087, 0.067, settings, [first, second])
    assert (third.outcome, third.next_frames) == ("out of reach", None)
    advice = ResponseFrameRecord((first, second, third), settings, 25).advice()
    assert "more frames will not do" in advice and "response.max_frames" not in advice


def test_every_prefix_of_the_refining_plan_is_a_thinned_scan():
    plan = refining_scan_plan(scan_plan((400, 640), "halogen", 0.1, (100, 5)), 25, 80)
    assert plan.steps[0].tags["role"] == "closed" and len(plan.steps) == 81
    offsets = [(s.tags["ox"], s.tags["oy"]) for s in plan.steps[1:]]
    assert set(offsets[:20]) == {(ox, oy) for oy in range(5) for ox in (0, 25, 50, 75)}
    assert {ox % 25 for ox, _ in offsets[20:40]} == {12}  # then halfway between
    assert len(set(offsets)) == 80
    assert [s.tags["frame"] for s in plan.steps[1:]] == list(range(80))
