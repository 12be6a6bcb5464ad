"""``--simulate``: a hardware rig's real adapters on simulators of its devices, with the
virtual bench behind them.

Each test runs in a child process: the simulated rig starts its own X server and sets
``DISPLAY`` for Qt, which must not meet the dummy X server of the other hardware tests.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from sassi_bench.rig.hardware.simulators import simulation_missing
from sassi_bench.rig.hardware.simulators.simavr_trigger import simavr_missing

REPO = Path(__file__).resolve().parents[3]
RIG = REPO / "tests" / "rigs" / "hardware-sim.yaml"

pytestmark = pytest.mark.skipif(
    simulation_missing() is not None, reason=f"{simulation_missing()} (.ci/run installs it)"
)


def child_env(tmp_path: Path) -> dict[str, str]:
    """A data root and a rig-lock folder of the test's own (a hardware rig is locked
    machine-wide), and no display: the simulated rig starts its own."""
    env = {
        **os.environ,
        "SASSI_BENCH_DATA": str(tmp_path / "data"),
        "SASSI_BENCH_LOCK_DIR": str(tmp_path / "locks"),
    }
    env.pop("DISPLAY", None)
    return env


def run_child(code: str, tmp_path: Path, timeout: int = 900) -> str:
    env = child_env(tmp_path)
    result = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=timeout,
        env=env,
        cwd=REPO,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def test_frames_come_through_the_adapters_and_the_trigger(tmp_path):
    out = run_child(
        f"""
        import numpy as np, pytest
        from sassi_bench.errors import DeviceError
        from sassi_bench.rig import open_rig
        from sassi_bench.rig.hardware.dcam import DcamCamera
        from sassi_bench.rig.hardware.genicam import GenICamCamera
        from sassi_bench.rig.hardware.slm_display import DisplaySlm
        from sassi_bench.rig.hardware.trigger import ArduinoTrigger

        rig = open_rig({str(RIG)!r}, simulate=True)
        sim = open_rig("sim")  # the same optics and seed as a plain virtual bench
        assert isinstance(rig.slm, DisplaySlm) and isinstance(rig.trigger, ArduinoTrigger)
        assert isinstance(rig.spectral_camera, DcamCamera)
        assert isinstance(rig.guide_camera, GenICamCamera)
        assert rig.guide_camera.pixel_format == "RGB8" and rig.guide_camera.trigger == "line"
        for r in (rig, sim):
            r.set_scene("white"); r.light.select("laser:532")
            r.spectral_camera.set_exposure(0.05)
        pattern = np.zeros(rig.slm.shape, np.uint8)
        pattern[20::40, 30::60] = 255
        rig.trigger.arm()
        before = rig.trigger.counters()
        rig.slm.show(pattern); sim.slm.show(pattern)
        frame = rig.spectral_camera.capture()
        after = rig.trigger.counters()
        # One pulse for the swap, then the line-triggered DCAM waits for two passed
        # pulses (a settling frame, then its own).
        print("pulses", after["received"] - before["received"], after["passed"] - before["passed"])
        expected = sim.spectral_camera.capture()
        # The pattern was read back from the virtual display and rendered by the bench:
        # the frame is the plain bench's, pixel for pixel.
        print("same", bool(np.array_equal(frame.data, expected.data)), frame.data.max())
        print("meta", frame.meta.pattern_id, frame.meta.light)
        rig.trigger.disarm()
        try:
            rig.spectral_camera.capture()
        except DeviceError as exc:
            print("disarmed:", str(exc).split(". Fix:")[0])
        rig.close()
        """,
        tmp_path,
    )
    assert "pulses 3 3" in out
    assert "same True" in out
    assert "meta 0 laser:532" in out
    assert "disarmed: spectral camera capture: no frame within 5 s" in out


def test_rig_check_and_calibrate_spectral_run_on_the_simulated_devices(tmp_path):
    script = Path(sys.executable).with_name("sassi-bench")
    env = child_env(tmp_path)
    check = subprocess.run(
        [str(script), "rig", "check", "--rig", str(RIG), "--simulate"],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    assert check.returncode == 0, check.stdout + check.stderr
    runs = "the trigger firmware in simavr" if simavr_missing() is None else "a serial fake"
    assert f"(simulated: {runs}" in check.stdout  # says which trigger runs
    assert "SLM window 640x400 on monitor DUMMY1" in check.stdout
    assert "FAIL" not in check.stdout and "every device answered" in check.stdout
    calibrate = subprocess.run(
        [str(script), "calibrate", "spectral", "--rig", str(RIG), "--simulate", "--quiet"],
        capture_output=True, text=True, timeout=1500, env=env,
    )  # fmt: skip
    assert calibrate.returncode == 0, calibrate.stdout[-2000:] + calibrate.stderr[-2000:]
    assert "all tolerances passed" in calibrate.stdout
    assert (tmp_path / "data" / "hardware-sim" / "v0001" / "manifest.json").is_file()
