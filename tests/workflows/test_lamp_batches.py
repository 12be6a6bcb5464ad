"""The lamp step measures until confident and resumes without taking a frame twice
(``workflows/spectral.py``: ``open_lamp_session``, ``capture_lamp_frames``)."""

from __future__ import annotations

import math

import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.plan_geometry import planned_spectral
from sassi_bench.acquire.runner import run_plan
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.lamps import captured_lamp_frames, lamp_frame_steps
from sassi_bench.workflows.spectral import capture_lamp_frames, open_lamp_session


class FrameCountSigma:
    """A laser's 1-sigma falling as one over the square root of the pinhole frames read
    from the session (so it needs those frames stored), counting its calls."""

    def __init__(self) -> None:
        self.calls: list[int] = []

    def __call__(self, session, frames: int) -> dict[float, float]:
        steps = lamp_frame_steps(session.plan, frames, role="lamp-pinholes")
        read = session.read_frames(steps)  # raises if a frame is missing
        per_lamp = read.shape[0] // len(session.plan.parameters["exposures_s"])
        self.calls.append(frames)
        return {670.0: 1.0 / math.sqrt(per_lamp), 520.0: 0.05}


@pytest.fixture(scope="module")
def rig_and_procedure():
    rig = open_rig("sim")
    proc = planned_spectral(load_procedure("spectral_calibration"), rig.description)
    # 2 frames: 0.71 nm; 2 * (0.71 / 0.45)**2 = 4.9, so 5 frames: 0.447 nm, met.
    proc["lamps"].update(frames=2, max_frames=8)
    proc["tolerances"]["laser_wavelength_sigma_nm"] = 0.45
    return rig, proc


def _steps_once(session) -> bool:
    steps = [event["step"] for event in session.events()]
    return len(steps) == len(set(steps))


def test_the_step_takes_batches_until_the_tolerance_is_met(rig_and_procedure, tmp_path):
    rig, proc = rig_and_procedure
    session = open_lamp_session(rig, proc, "t-lamps", data=tmp_path)
    assert len(session.plan.select(role="lamp-pinholes")) == 8 * 2  # the budget, 2 lamps
    record = capture_lamp_frames(rig, session, proc, FrameCountSigma(), progress=False)
    assert [b.frames for b in record.batches] == [2, 5]
    assert [b.outcome for b in record.batches] == ["more frames", "tolerance met"]
    assert record.frames == 5 and record.advice() is None
    # 5 pinhole and 5 closed frames of each of the 2 lamps, nothing more.
    assert len(session.completed) == 5 * 2 * 2 and captured_lamp_frames(session) == 5
    assert _steps_once(session)


def test_a_resumed_step_replays_its_decisions_and_takes_no_frame_twice(rig_and_procedure, tmp_path):
    rig, proc = rig_and_procedure
    session = open_lamp_session(rig, proc, "r-lamps", data=tmp_path)
    # An earlier run stopped in its second batch: the first batch stored, 5 frames of the
    # second (it had decided on 5 frames per lamp).
    run_plan(rig, session.plan, session, progress=False, steps=lamp_frame_steps(session.plan, 2))
    steps = lamp_frame_steps(session.plan, 5)
    run_plan(rig, session.plan, session, progress=False, steps=steps, stop_after=5)
    assert len(session.completed) == 8 + 5
    resumed = open_lamp_session(rig, proc, "r-lamps", data=tmp_path)
    measure = FrameCountSigma()
    record = capture_lamp_frames(rig, resumed, proc, measure, progress=False)
    # The same decisions on the same frames; only the 7 frames still missing are taken.
    assert measure.calls == [2, 5] and [b.frames for b in record.batches] == [2, 5]
    assert len(resumed.completed) == 20 and _steps_once(resumed)
    # Run again when complete: the same record, no frame taken.
    again = capture_lamp_frames(rig, resumed, proc, FrameCountSigma(), progress=False)
    assert again.to_json() == record.to_json() and len(resumed.events()) == 20


def test_the_step_stops_at_the_budget_and_says_so(rig_and_procedure, tmp_path):
    rig, proc = rig_and_procedure
    strict = {**proc, "tolerances": {**proc["tolerances"], "laser_wavelength_sigma_nm": 0.2}}
    session = open_lamp_session(rig, strict, "b-lamps", data=tmp_path)
    record = capture_lamp_frames(rig, session, strict, FrameCountSigma(), progress=False)
    # 0.71 nm at 2 frames asks for 25: the budget of 8, then stop there.
    assert [b.frames for b in record.batches] == [2, 8]
    assert record.outcome == "budget spent" and len(session.completed) == 8 * 2 * 2
    assert "take about 25 lamp frames per lamp" in record.advice()  # 8 * (0.354 / 0.2)**2
