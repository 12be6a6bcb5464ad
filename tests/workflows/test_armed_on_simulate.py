"""Captures outside a plan arm the trigger: the live snapshot's capture thread, the
Macbeth validation's guide picture and the live view, through the real adapters of
``tests/rigs/hardware-sim.yaml`` on its simulated devices (cameras on a line trigger: a
capture with the trigger disarmed gets no frame).

Run in a child process: the simulated rig starts its own X server and sets ``DISPLAY``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from sassi_bench.rig.hardware.simulators import simulation_missing

REPO = Path(__file__).resolve().parents[2]
RIG = REPO / "tests" / "rigs" / "hardware-sim.yaml"

pytestmark = pytest.mark.skipif(
    simulation_missing() is not None, reason=f"{simulation_missing()} (.ci/run installs it)"
)

CHILD = f"""
import types
import numpy as np
from sassi_bench.rig import open_rig
from sassi_bench.workflows.live_view import alignment_feed
from sassi_bench.workflows.macbeth import guide_picture
from sassi_bench.workflows.snapshot_live import _Capture

rig = open_rig({str(RIG)!r}, simulate=True)
rig.set_scene("white")
rig.light.select("led")
mask = np.zeros(rig.slm.shape, np.uint8)
mask[::20, ::20] = 255
capture = _Capture(rig, "white", None, (mask, None), 2, None, 4)
capture.start()
capture.join()
print("snapshot live", capture.captured, repr(capture.error), rig.trigger.armed)

identity = types.SimpleNamespace(
    guide_to_slm=np.eye(3), warp_guide_to_slm=lambda image: image
)
picture = guide_picture(rig, identity, "led")
print("macbeth guide picture", picture.shape, rig.trigger.armed)

with alignment_feed(rig, ["led"], live_exposure_s=0.05, readings_every_s=60) as feed:
    frame = feed.latest["guide"].wait_newer(-1, timeout=120)
print("live view", frame is not None, repr(feed.error), rig.trigger.armed)
rig.close()
"""


def test_captures_outside_a_plan_arm_the_trigger(tmp_path):
    env = {
        **os.environ,
        "SASSI_BENCH_DATA": str(tmp_path / "data"),
        "SASSI_BENCH_LOCK_DIR": str(tmp_path / "locks"),
    }
    env.pop("DISPLAY", None)
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(CHILD)],
        capture_output=True, text=True, timeout=600, env=env, cwd=REPO,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr[-3000:]
    lines = result.stdout.splitlines()
    assert "snapshot live 2 None False" in lines  # both frames; disarmed afterwards
    assert "macbeth guide picture (400, 600, 3) False" in lines
    assert "live view True None False" in lines
