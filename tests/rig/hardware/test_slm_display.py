"""The SLM window on the second head of a dummy X server, checked pixel for pixel."""

import os
import subprocess
import sys
import time

import numpy as np
import pytest

from sassi_bench.errors import DeviceError

SHAPE = (400, 640)  # conftest's SLM monitor DUMMY1, right of DUMMY0 (800x600)


def grab(dummy_x, expected, timeout_s=30.0):
    """The SLM monitor's pixels (waiting until the X server has the new frame; a loaded
    machine can starve the X server for seconds, and a match returns at once)."""
    import mss

    _, width, height, left, top = dummy_x.slm
    region = {"left": left, "top": top, "width": width, "height": height}
    deadline = time.monotonic() + timeout_s
    with mss.MSS(display=dummy_x.display) as screen:
        while True:
            pixels = np.asarray(screen.grab(region))[..., :3]  # BGRA
            if np.array_equal(pixels[..., 1], expected) or time.monotonic() > deadline:
                return pixels


@pytest.fixture(scope="module")
def slm(dummy_x):
    from sassi_bench.rig.hardware.slm_display import DisplaySlm

    device = DisplaySlm(SHAPE, monitor="DUMMY1")
    yield device
    device.close()


def test_patterns_are_shown_pixel_for_pixel(slm, dummy_x):
    rng = np.random.default_rng(7)
    noise = rng.integers(0, 256, SHAPE, dtype=np.uint8)  # any scaling or smoothing shows
    slm.show(noise)
    pixels = grab(dummy_x, noise)
    for channel in range(3):
        assert np.array_equal(pixels[..., channel], noise)
    checker = (np.indices(SHAPE).sum(axis=0) % 2).astype(bool)  # 1-px checkerboard
    slm.show(checker)
    assert np.array_equal(grab(dummy_x, checker * np.uint8(255))[..., 0], checker * 255)
    assert slm.monitor.name == "DUMMY1" and slm.monitor.x == 800


def test_monitor_by_index_and_errors(dummy_x, slm):
    from sassi_bench.rig.hardware.slm_display import DisplaySlm

    with pytest.raises(DeviceError, match=r"monitor DUMMY0 is 800x600, the rig's SLM is 640x400"):
        DisplaySlm(SHAPE, monitor=0)
    with pytest.raises(DeviceError, match=r"no monitor 'HDMI-9'; connected: 0: DUMMY0 800x600, 1:"):
        DisplaySlm(SHAPE, monitor="HDMI-9")
    with pytest.raises(DeviceError, match="no monitor 5"):
        DisplaySlm(SHAPE, monitor=5)


def test_a_qt_that_draws_offscreen_is_refused_with_its_cause(dummy_x):
    """An offscreen Qt would show every pattern to no one: refused before any capture.
    Run in a child process, since a process has one Qt platform for its lifetime."""
    code = (
        "from sassi_bench.errors import DeviceError\n"
        "from sassi_bench.rig.hardware.slm_display import DisplaySlm\n"
        "try:\n"
        f"    DisplaySlm({SHAPE!r}, monitor='DUMMY1')\n"
        "except DeviceError as exc:\n"
        "    print(exc)\n"
    )
    env = {**os.environ, "DISPLAY": dummy_x.display, "QT_QPA_PLATFORM": "offscreen"}
    child = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120
    )
    assert "SLM display" in child.stdout and "'offscreen' platform" in child.stdout
    assert "unset QT_QPA_PLATFORM" in child.stdout
