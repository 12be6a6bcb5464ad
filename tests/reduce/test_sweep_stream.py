"""The sweep decoded as it is captured equals the sweep decoded from its session."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.acquire.frame_feed import FrameFeed
from sassi_bench.acquire.plan_geometry import planned_spectral
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import sweep_plan
from sassi_bench.calibrate.grey_response import sinusoid_profile
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.sweep_stream import SweepStream
from sassi_bench.reduce.sweeps import _structured_decode, pinhole_signal


@pytest.fixture(scope="module")
def interrupted_capture(sim_rig, tmp_path_factory):
    """A one-laser sweep captured in three runs (stopped twice), decoded as it came."""
    rig = sim_rig
    proc = planned_spectral(load_procedure("spectral_calibration"), rig.description)
    rig.set_scene("white")
    plan = sweep_plan(proc, rig.slm.shape, {532.0: 0.02}, sinusoid_profile(16).tolist())
    data = tmp_path_factory.mktemp("sweep-stream")
    session = Session.create(rig.description, plan, session_id="s", data=data)
    for stop in (7, 25, None):  # an interruption in the Gray frames, one in the phase frames
        stream = SweepStream(plan, proc, rig.slm.shape, 65535)
        with FrameFeed(session, stream.steps, stream.add) as feed:
            run_plan(rig, plan, feed.tee(), progress=False, stop_after=stop)
            feed.finish()
    assert session.is_complete
    return proc, session, stream.result()


def test_decoding_during_capture_equals_decoding_the_session(sim_rig, interrupted_capture):
    proc, session, live = interrupted_capture
    after = _structured_decode(session, proc, 532.0, sim_rig.slm.shape, 65535)
    decoded = live.decodes[532.0]
    for name in ("camera_x", "camera_y", "slm_u", "slm_v"):
        assert np.array_equal(getattr(decoded, name), getattr(after, name))
    assert decoded.counts == after.counts and decoded.valid_fraction == after.valid_fraction
    assert decoded.valid_fraction > 0.9 and decoded.counts["x_valid"] > 100_000


def test_pinhole_frames_averaged_during_capture_equal_the_session_s(interrupted_capture):
    _, session, live = interrupted_capture
    after = pinhole_signal(session, 532.0, 65535)
    assert np.array_equal(live.pinholes[532.0].signal, after.signal)
    assert np.array_equal(live.pinholes[532.0].saturated, after.saturated)
    assert after.signal.max() > 1000  # the pinholes are lit
