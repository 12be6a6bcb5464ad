"""Frames handed to a consumer as the session fills: plan order, resume, errors."""

from __future__ import annotations

import threading

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.frame_feed import THREAD_PREFIX, FrameFeed
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.errors import ProcedureError
from sassi_bench.rig import Frame, FrameMeta


def _plan(n: int) -> Plan:
    return Plan(
        "levels",
        [Step("spectral", "off", 0.01, {"kind": "uniform", "level": 10 * i}) for i in range(n)],
    )


def _frame(i: int) -> Frame:
    return Frame(np.full((3, 4), i, np.uint16), FrameMeta("spectral", 0.01, 0.0, i, "off", i))


@pytest.fixture()
def session(tmp_path, sim_rig):
    return Session.create(sim_rig.description, _plan(6), session_id="feed", data=tmp_path)


@pytest.mark.parametrize("threaded", [True, False])
def test_stored_and_captured_frames_come_in_plan_order(session, threaded):
    for i in (0, 1, 4):  # stored before this run, with a gap
        session.write_frame(i, _frame(i))
    seen: list[tuple[int, int]] = []
    threads: set[str] = set()

    def consume(i, frame):
        threads.add(threading.current_thread().name)
        seen.append((i, int(frame[0, 0])))

    with FrameFeed(session, [1, 2, 3, 4, 5], consume, threaded=threaded) as feed:
        for i in (2, 3, 5):  # what run_plan would capture now, in plan order
            feed.tee().write_frame(i, _frame(i))
        feed.finish()
    assert seen == [(i, i) for i in (1, 2, 3, 4, 5)]
    assert session.completed == frozenset(range(6))
    assert all(name.startswith(THREAD_PREFIX) for name in threads) == threaded


def test_missing_steps_are_skipped_at_the_end(session):
    session.write_frame(3, _frame(3))
    seen = []
    with FrameFeed(session, range(6), lambda i, f: seen.append(i)) as feed:
        feed.finish()
    assert seen == [3]


@pytest.mark.parametrize("threaded", [True, False])
def test_a_consumer_error_stops_the_capture_after_storing_its_frame(tmp_path, threaded):
    rig = open_rig("sim")
    session = Session.create(rig.description, _plan(6), session_id="bad", data=tmp_path)

    def consume(i, frame):
        if i == 2:
            raise ProcedureError("decoding: frame 2 is wrong. Fix: none")

    with (
        FrameFeed(session, range(6), consume, threaded=threaded) as feed,
        pytest.raises(ProcedureError, match="frame 2 is wrong"),
    ):
        run_plan(rig, session.plan, feed.tee(), progress=False)
        feed.finish()
    assert 2 in session.completed  # the frame is kept; a resumed run takes it up again
    if not threaded:  # in the capture's own thread the error stops it at once
        assert session.completed == frozenset({0, 1, 2})


def test_leaving_early_stops_the_worker(session):
    release = threading.Event()
    seen = []

    def slow(i, frame):
        release.wait(5)
        seen.append(i)

    with pytest.raises(KeyboardInterrupt), FrameFeed(session, range(6), slow, depth=1) as feed:
        feed.tee().write_frame(0, _frame(0))
        feed.tee().write_frame(1, _frame(1))
        release.set()
        raise KeyboardInterrupt
    assert not [t for t in threading.enumerate() if t.name.startswith(THREAD_PREFIX)]
    assert seen[:1] == [0] and len(seen) <= 2


def test_a_step_stored_out_of_order_is_refused(session):
    with FrameFeed(session, range(6), lambda i, f: None, threaded=False) as feed:
        feed.tee().write_frame(0, _frame(0))
        with pytest.raises(ProcedureError, match="step 2 was stored before step 1"):
            feed.tee().write_frame(2, _frame(2))
