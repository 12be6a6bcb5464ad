"""A scan assembled while it is captured equals the scan assembled from its session."""

from __future__ import annotations

import numpy as np

from sassi_bench import open_rig
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.reduce.scan import assemble_scan
from sassi_bench.workflows.scan import capture_scan


def test_a_scan_assembled_as_captured_and_resumed_equals_the_session_s(calibrated_sim):
    _, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    full = scan_plan((400, 640), "led", 0.1, scene="colorchecker")
    keep = [s for i, s in enumerate(full.steps) if s.tags["role"] == "closed" or i % 40 == 1]
    plan = Plan(full.name, tuple(keep), full.parameters)
    session = Session.create(open_rig("sim").description, plan, session_id="feed", data=data)
    # Interrupted after 5 frames (a Ctrl-C), then resumed on a fresh rig: the resumed run
    # reads the 5 stored frames back and takes the rest as they are captured.
    run_plan(open_rig("sim"), plan, session, progress=False, stop_after=5)
    live = capture_scan(open_rig("sim"), session, bundle, keep_raw=True, progress=False)
    assert session.is_complete
    after = assemble_scan(session, bundle, keep_raw=True, progress=False)
    for name in ("cube", "quality", "background", "column_sums", "noise_variance"):
        assert np.array_equal(getattr(live, name), getattr(after, name), equal_nan=True), name
    assert live.problems == after.problems and live.deblur == after.deblur
    assert live.background_check_rms == after.background_check_rms
    assert (live.quality == 0).sum() > 5000
