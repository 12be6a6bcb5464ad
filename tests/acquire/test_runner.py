"""The plan runner on the virtual bench: order, devices, interruption and resumption."""

from __future__ import annotations

import dataclasses
import os
import signal

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session, SessionError


@pytest.fixture()
def plan(pinhole_step) -> Plan:
    """Four spectral pinhole frames at 532 nm and one guide frame under the LED."""
    guide = Step("guide", "led", 0.02, {"kind": "blank"}, {"role": "guide"})
    steps = [pinhole_step(0), pinhole_step(1), pinhole_step(2), guide, pinhole_step(3)]
    return Plan("pinholes", steps, {"pitch": [100, 50]})


class Recorder:
    """Wraps a device and records the calls made to it (and the trigger state)."""

    def __init__(self, device, log, name, rig_ref=None, fail_at=None):
        self._device, self._log, self._name = device, log, name
        self._rig_ref, self._fail_at = rig_ref, fail_at

    def __getattr__(self, attr):
        value = getattr(self._device, attr)
        if not callable(value):
            return value

        def call(*args, **kwargs):
            armed = self._rig_ref[0].trigger.armed if self._rig_ref else None
            self._log.append((self._name, attr, armed))
            if attr == "capture" and self._fail_at is not None:
                captures = sum(1 for n, a, _ in self._log if a == "capture")
                if captures == self._fail_at:
                    raise self._fail_exc
            return value(*args, **kwargs)

        return call


def recorded_rig(log, fail_at=None, fail_exc=KeyboardInterrupt):
    rig = open_rig("sim")
    ref = [rig]
    spectral = Recorder(rig.spectral_camera, log, "spectral", ref, fail_at)
    spectral._fail_exc = fail_exc
    wrapped = dataclasses.replace(
        rig,
        spectral_camera=spectral,
        guide_camera=Recorder(rig.guide_camera, log, "guide", ref),
        light=Recorder(rig.light, log, "light"),
    )
    ref[0] = wrapped
    return wrapped


def create(rig, plan, data, session_id):
    return Session.create(rig.description, plan, session_id=session_id, data=data)


def test_interrupted_run_resumes_on_a_fresh_rig_to_identical_frames(plan, data):
    full = run_plan(
        open_rig("sim"), plan, create(open_rig("sim"), plan, data, "full"), progress=False
    )
    assert full.is_complete

    rig = open_rig("sim")
    part = run_plan(rig, plan, create(rig, plan, data, "part"), progress=False, stop_after=2)
    assert part.completed == {0, 1} and part.missing == (2, 3, 4)
    assert not rig.trigger.armed

    resumed = run_plan(open_rig("sim"), plan, Session.open("part", data=data), progress=False)
    assert resumed.is_complete and resumed.missing == ()
    # The virtual bench keys its noise by what each frame sees, so a capture resumed on a
    # freshly opened rig ends with exactly the frames of an uninterrupted one.
    for i in range(len(plan)):
        np.testing.assert_array_equal(resumed.read_frame(i), full.read_frame(i))
    assert resumed.read_frame(2).shape == (512, 800) and resumed.read_frame(2).dtype == np.uint16
    assert resumed.read_frame(3).shape == (400, 600, 3)
    assert resumed.verify() == 5
    meta = [e["meta"] for e in resumed.events()]
    assert [m["light"] for m in meta] == ["laser:532"] * 3 + ["led", "laser:532"]
    assert [m["exposure_s"] for m in meta] == [0.01, 0.01, 0.01, 0.02, 0.01]
    # Running a complete session again captures nothing.
    assert run_plan(open_rig("sim"), plan, resumed, progress=False).sha256() == resumed.sha256()


def test_chosen_steps_are_captured_alone_in_plan_order(plan, data):
    rig = open_rig("sim")
    session = create(rig, plan, data, "chosen")
    run_plan(rig, plan, session, progress=False, steps=[4, 1])
    assert session.completed == {1, 4} and [e["step"] for e in session.events()] == [1, 4]
    # Chosen again with one more: only the new one is taken; the rest stays missing.
    run_plan(rig, plan, session, progress=False, steps=[1, 2, 4], stop_after=5)
    assert [e["step"] for e in session.events()] == [1, 4, 2] and session.missing == (0, 3)


def test_devices_are_driven_in_order_with_the_trigger_armed(plan, data):
    log: list = []
    rig = recorded_rig(log)
    session = run_plan(rig, plan, create(rig, plan, data, "s"), progress=False)
    assert session.is_complete and not rig.trigger.armed
    selects = [attr for name, attr, _ in log if name == "light" and attr == "select"]
    assert len(selects) == 3  # 532, led, 532: only when the light changes
    captures = [(name, armed) for name, attr, armed in log if attr == "capture"]
    assert captures == [("spectral", True)] * 3 + [("guide", True), ("spectral", True)]
    # Each spectral frame saw its own pattern: pinholes move by one SLM column per step.
    ids = [e["meta"]["pattern_id"] for e in session.events()]
    assert ids == sorted(ids) and len(set(ids)) == 5


def test_keyboard_interrupt_keeps_finished_frames_and_disarms(plan, data):
    log: list = []
    rig = recorded_rig(log, fail_at=3)
    session = create(rig, plan, data, "s")
    with pytest.raises(KeyboardInterrupt):
        run_plan(rig, plan, session, progress=False)
    assert not rig.trigger.armed
    assert Session.open("s", data=data).completed == {0, 1}
    assert run_plan(open_rig("sim"), plan, session, progress=False).is_complete


def test_device_errors_disarm_the_trigger_and_keep_frames(plan, data):
    rig = recorded_rig([], fail_at=2, fail_exc=RuntimeError("camera timeout"))
    session = create(rig, plan, data, "s")
    with pytest.raises(RuntimeError, match="camera timeout"):
        run_plan(rig, plan, session, progress=False)
    assert not rig.trigger.armed and session.completed == {0}


def _ctrl_c_while_storing_frame_1(monkeypatch):
    """Send SIGINT to this process in the middle of storing frame 1."""
    original = Session.write_frame

    def interrupted_write(self, step_index, frame):
        if step_index == 1:
            os.kill(os.getpid(), signal.SIGINT)  # arrives mid-write
        original(self, step_index, frame)

    monkeypatch.setattr(Session, "write_frame", interrupted_write)


def test_ctrl_c_while_storing_a_frame_waits_for_the_frame(plan, data, monkeypatch):
    rig = open_rig("sim")
    session = create(rig, plan, data, "s")
    _ctrl_c_while_storing_frame_1(monkeypatch)
    # Python's own Ctrl-C handler, also when the tests run as a background job (SIG_IGN).
    before = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(KeyboardInterrupt):
            run_plan(rig, plan, session, progress=False)
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, before)
    # Frame 1 is whole; so is frame 2 if its capture had ended when the Ctrl-C came
    # (frames are stored while the next is captured), and nothing later was captured.
    assert {0, 1} <= session.completed <= {0, 1, 2}
    assert Session.open("s", data=data).verify() == len(session.completed)


def test_ctrl_c_is_not_raised_where_it_is_ignored(plan, data, monkeypatch):
    rig = open_rig("sim")
    session = create(rig, plan, data, "s")
    _ctrl_c_while_storing_frame_1(monkeypatch)
    before = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        run_plan(rig, plan, session, progress=False)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, before)
    assert session.completed == set(range(len(plan)))


def test_progress_bar_counts_the_whole_plan(plan, data, capsys):
    rig = open_rig("sim")
    session = create(rig, plan, data, "s")
    run_plan(rig, plan, session, progress=False, stop_after=3)
    assert capsys.readouterr().err == ""
    run_plan(rig, plan, session, progress=True)
    err = capsys.readouterr().err
    assert "pinholes" in err and "5/5" in err and "0/5" not in err


def test_a_bad_step_is_refused_before_any_capture(data, pinhole_step):
    bad = Step(
        "spectral",
        "laser:532",
        0.01,
        {"kind": "gray", "axis": "q", "bit": 0, "block": 8, "inverse": False},
    )
    plan = Plan("bad", [pinhole_step(0), bad])
    log: list = []
    rig = recorded_rig(log)
    session = create(rig, plan, data, "s")
    with pytest.raises(ValueError, match=r"step 1: pattern .* cannot be rendered"):
        run_plan(rig, plan, session, progress=False)
    long = Plan("long", [Step("spectral", "led", 1e6, {"kind": "full"})])
    with pytest.raises(ValueError, match=r"step 0: exposure 1e\+06 s is outside"):
        run_plan(rig, long, create(rig, long, data, "l"), progress=False)
    assert log == [] and session.completed == frozenset() and not rig.trigger.armed


def test_session_of_another_plan_or_rig_is_refused(plan, data, pinhole_step, sim_dict, make_rig):
    rig = open_rig("sim")
    session = create(rig, plan, data, "s")
    with pytest.raises(SessionError, match="created for plan 'pinholes'"):
        run_plan(rig, Plan("x", [pinhole_step(0)]), session, progress=False)
    sim_dict["seed"] = 5
    with pytest.raises(SessionError, match="another rig description"):
        run_plan(make_rig(sim_dict), plan, session, progress=False)
    with pytest.raises(ValueError, match="stop_after"):
        run_plan(rig, plan, session, progress=False, stop_after=-1)


def test_scene_parameter_is_set_before_capturing(data, pinhole_step):
    plan = Plan("chart", [pinhole_step(0)], {"scene": "colorchecker"})
    rig = open_rig("sim")
    session = run_plan(rig, plan, create(rig, plan, data, "s"), progress=False)
    assert rig.scene == "colorchecker"
    assert session.events()[0]["meta"]["extra"]["scene"] == "colorchecker"


def test_a_complete_session_asks_for_no_scene_and_moves_no_device(data, pinhole_step):
    plan = Plan("chart", [pinhole_step(0)], {"scene": "colorchecker"})
    rig = open_rig("sim")
    session = run_plan(rig, plan, create(rig, plan, data, "s"), progress=False)
    # A resumed procedure passes every stage's session through the runner again: on a real
    # bench a scene request is the operator placing a target, so a finished stage asks none.
    log: list = []
    placed: list = []
    again = recorded_rig(log)
    again = dataclasses.replace(again, scene_setter=lambda *args: placed.append(args))
    assert run_plan(again, plan, session, progress=False).sha256() == session.sha256()
    assert placed == [] and log == [] and again.trigger.counters()["received"] == 0


def test_a_session_being_written_elsewhere_is_refused_before_any_device_moves(plan, data):
    from sassi_bench.acquire.session import SessionLockedError

    log: list = []
    rig = recorded_rig(log)
    holder = create(rig, plan, data, "busy")
    locked = pytest.raises(SessionLockedError, match="another writer holds the session")
    with holder.writing(), locked:
        run_plan(rig, plan, Session.open("busy", data=data), progress=False)
    assert log == [] and Session.open("busy", data=data).completed == frozenset()
    assert run_plan(rig, plan, Session.open("busy", data=data), progress=False).is_complete


def _slow_writes(monkeypatch, seconds, log):
    """Make every frame's storing take ``seconds`` and log its start and end."""
    import time

    original = Session.write_frame

    def slow(self, step_index, frame):
        log.append(("write", step_index, time.perf_counter()))
        time.sleep(seconds)
        original(self, step_index, frame)
        log.append(("stored", step_index, time.perf_counter()))

    monkeypatch.setattr(Session, "write_frame", slow)


def test_a_run_that_cannot_fit_on_its_disk_is_refused_before_any_device_moves(
    plan, data, monkeypatch
):
    import sassi_bench.acquire.runner as runner

    log: list = []
    rig = recorded_rig(log)
    session = create(rig, plan, data, "small-disk")
    # Four 512 x 800 spectral frames and one 400 x 600 RGB guide frame, 16 bits a value.
    need = (4 * 512 * 800 + 400 * 600 * 3) * 2 * runner.LEAST_STORED_SHARE
    monkeypatch.setattr(runner, "free_bytes", lambda path: int(need) - 1)
    with pytest.raises(SessionError, match="run plan 'pinholes': its 5 frames to capture"):
        run_plan(rig, plan, session, progress=False)
    assert log == [] and rig.trigger.counters()["received"] == 0
    monkeypatch.setattr(runner, "free_bytes", lambda path: int(need) + 1)
    assert run_plan(rig, plan, session, progress=False).is_complete


def test_a_frame_is_stored_while_the_next_is_captured(plan, data, monkeypatch):
    import threading

    # The first frame's storing waits for the second capture: it can only come while the
    # first frame is still being stored. (The wait's limit only keeps a sequential runner
    # from hanging the suite.)
    second_captured = threading.Event()
    overlapped: list[bool] = []
    original = Session.write_frame

    def write_after_the_next_capture(self, step_index, frame):
        if step_index == 0:
            overlapped.append(second_captured.wait(timeout=30))
        original(self, step_index, frame)

    monkeypatch.setattr(Session, "write_frame", write_after_the_next_capture)
    rig = open_rig("sim")
    capture = rig.spectral_camera.capture
    captures: list[int] = []

    def counted_capture():
        captures.append(len(captures))
        if len(captures) == 2:
            second_captured.set()
        return capture()

    monkeypatch.setattr(rig.spectral_camera, "capture", counted_capture)
    session = run_plan(rig, plan, create(rig, plan, data, "s"), progress=False)
    assert session.is_complete and session.verify() == len(plan)
    assert [e["step"] for e in session.events()] == list(range(len(plan)))  # in plan order
    assert overlapped == [True]  # the second frame was captured while the first was stored


def test_ctrl_c_during_a_capture_still_stores_the_frames_being_written(plan, data, monkeypatch):
    log: list = []
    _slow_writes(monkeypatch, 0.5, log)
    rig = recorded_rig([], fail_at=3)  # the third capture is interrupted
    session = create(rig, plan, data, "s")
    with pytest.raises(KeyboardInterrupt):
        run_plan(rig, plan, session, progress=False)
    # Both frames captured before the interrupt were still being stored; both are whole.
    reopened = Session.open("s", data=data)
    assert reopened.completed == {0, 1} and reopened.verify() == 2
    assert not rig.trigger.armed
    assert run_plan(open_rig("sim"), plan, reopened, progress=False).is_complete


def test_a_failed_write_stops_the_run_and_the_rest_is_captured_on_resume(plan, data, monkeypatch):
    original = Session.write_frame

    def failing(self, step_index, frame):
        if step_index == 1:
            raise OSError("disk full")
        original(self, step_index, frame)

    monkeypatch.setattr(Session, "write_frame", failing)
    rig = open_rig("sim")
    session = create(rig, plan, data, "s")
    with pytest.raises(OSError, match="disk full"):
        run_plan(rig, plan, session, progress=False)
    assert not rig.trigger.armed
    assert Session.open("s", data=data).completed == {0}  # nothing after the failure
    monkeypatch.setattr(Session, "write_frame", original)
    full = run_plan(open_rig("sim"), plan, Session.open("s", data=data), progress=False)
    assert full.is_complete and full.verify() == len(plan)
