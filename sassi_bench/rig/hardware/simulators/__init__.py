"""A real rig rehearsed without its hardware: every adapter against a simulator of its device.

``--simulate`` opens a ``backend: hardware`` rig through its real adapters with these in
place of the devices (as ophyd-async's mocks, catkit2's simulated services or
pymmcore-plus's demo configuration let a lab run its own configuration):

- the trigger: the firmware itself in simavr (:class:`~.simavr_trigger.SimavrTrigger`)
  where avr-gcc and libsimavr are installed, else :class:`~.serial_trigger.TriggerSimulator`
  speaking the firmware's protocol; either on a pseudo-terminal the
  :class:`~sassi_bench.rig.hardware.trigger.ArduinoTrigger` driver opens as a serial port
  (``Rig.simulated_by["trigger"]`` says which one runs);
- the SLM: the :class:`~sassi_bench.rig.hardware.slm_display.DisplaySlm` window opens full
  screen on the SLM monitor of a virtual X server (:class:`~.display.DummyXServer`), every
  pattern it paints sends a master pulse to the trigger, and the pixels the server
  displays are grabbed back for the bench;
- the cameras: the GenICam and DCAM adapters drive simulators of harvesters' and
  pylablib's APIs (:mod:`.cameras`) whose frames the bench renders from the displayed
  pattern; a line-triggered camera gets a frame only for an SLM pulse the trigger passed;
- the lights and targets: an operator who does as asked (the bench switches the light
  and places the target).

The bench behind them is the rig's own optics (:class:`BenchBehind`; built by the rig
package's face, so no procedure reaches it). What is left out: the adapters' discovery
of devices (serial port enumeration, GenTL producers, the DCAM runtime) is not run.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import DeviceError, step_error
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.hardware import require
from sassi_bench.rig.hardware.manual import ManualLight
from sassi_bench.rig.rig import Rig
from sassi_bench.rig.scene_pose import ScenePose

__all__ = ["BenchBehind", "SimulatedRig", "build_simulated_rig", "simulation_missing"]

#: How long a pattern may take to reach the virtual display's pixels.
_READBACK_S = 2.0


class BenchBehind(Protocol):
    """What the simulated devices look at (the virtual bench with the rig's optics)."""

    spectral_shape: tuple[int, int]
    guide_shape: tuple[int, int, int]
    spectral_bits: int
    guide_bits: int

    def show(self, pattern: NDArray[np.uint8]) -> None: ...

    def set_light(self, name: str) -> None: ...

    def set_scene(self, name: str, pose: ScenePose | None = None) -> None: ...

    def spectral(self, exposure_s: float) -> NDArray[Any]: ...

    def guide(self, exposure_s: float) -> NDArray[Any]: ...


def simulation_missing() -> str | None:
    """Why a simulated rig cannot open here (the fix included), or None.

    Examples
    --------
    >>> simulation_missing() is None or "install" in simulation_missing()
    True
    """
    from sassi_bench.rig.hardware.simulators.display import xorg_missing

    reason = xorg_missing()
    if reason:
        return f"the virtual display cannot start: {reason}"
    for module, package in (("PySide6.QtWidgets", "PySide6"), ("screeninfo", "screeninfo")):
        try:
            require(module, package, "simulated rig")
        except DeviceError as exc:
            return str(exc)
    try:
        require("mss", "mss", "simulated rig")
    except DeviceError as exc:
        return str(exc)
    return None


class _OperatorLight(ManualLight):
    """The operator's lights, switched on the bench as the operator is asked."""

    def __init__(self, desc: RigDescription, behind: BenchBehind) -> None:
        super().__init__(desc.lasers_nm, desc.wavelength_lamps, prompt=self._obey)
        self._behind = behind
        self.instructions: list[str] = []

    def _obey(self, message: str) -> None:
        self.instructions.append(message)

    def _switch(self, name: str) -> None:
        super()._switch(name)
        self._behind.set_light(name)


class SimulatedRig:
    """The simulators behind one simulated rig, and how to stop them.

    Attributes
    ----------
    rig
        The rig of real adapters.
    trigger
        The trigger simulator (:func:`~.simavr_trigger.trigger_simulator`).
    display
        The virtual X server.
    readbacks, stale_readbacks
        Patterns grabbed from the display, and those that still differed from the
        pattern shown after :data:`_READBACK_S`.
    """

    def __init__(self, workdir: Path) -> None:
        self.workdir = workdir
        self.rig: Rig | None = None
        self.trigger: Any = None
        self.display: Any = None
        self.readbacks = 0
        self.stale_readbacks = 0
        self._closers: list[Callable[[], None]] = []
        self._old_env = {key: os.environ.get(key) for key in ("DISPLAY", "QT_QPA_PLATFORM")}

    def on_close(self, closer: Callable[[], None]) -> None:
        self._closers.append(closer)

    def close(self) -> None:
        """Close the adapters, then the simulators; remove the work folder."""
        while self._closers:
            with contextlib.suppress(Exception):
                self._closers.pop()()
        for key, value in self._old_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value
        shutil.rmtree(self.workdir, ignore_errors=True)


def _camera(
    name: str,
    spec: dict[str, Any],
    render: Callable[[float], NDArray[Any]],
    shape: tuple[int, ...],
    bits: int,
    exposure_range_s: tuple[float, float],
    refresh: Callable[[], bool],
    state: Callable[[], tuple[int | None, str]],
) -> Any:
    """The adapter of ``spec``'s kind on its API's simulator."""
    from sassi_bench.rig.hardware.simulators.cameras import SimulatedAcquirer, SimulatedDcam

    kind = spec.get("kind")
    common = {"timeout_s": spec.get("timeout_s", 5.0), "state": state}
    if "exposure_range_s" in spec:
        common["exposure_range_s"] = spec["exposure_range_s"]
    api = {
        "shape": shape,
        "bit_depth": bits,
        "exposure_range_s": exposure_range_s,
        "refresh": refresh,
    }
    if kind == "genicam":
        from sassi_bench.rig.hardware.genicam import GenICamCamera

        return GenICamCamera(
            name,
            SimulatedAcquirer(render, **api),
            pixel_format=spec.get("pixel_format"),
            trigger=spec.get("trigger", "auto"),
            trigger_line=spec.get("trigger_line", "Line0"),
            **common,
        )
    if kind == "dcam":
        from sassi_bench.rig.hardware.dcam import DcamCamera

        return DcamCamera(
            name,
            SimulatedDcam(render, **{**api, "shape": shape[:2]}),
            trigger=spec.get("trigger", "none"),
            bit_depth=spec.get("bit_depth", 16),
            **common,
        )
    raise DeviceError(
        step_error(
            f"{name} camera (simulated)",
            f"there is no simulator of camera kind {kind!r}",
            "rehearse with a genicam or dcam camera, or add a simulator of its API to "
            "sassi_bench/rig/hardware/simulators/cameras.py",
        )
    )


def build_simulated_rig(desc: RigDescription, behind: BenchBehind) -> SimulatedRig:
    """Open a hardware rig's real adapters against simulators of its devices.

    Parameters
    ----------
    desc
        A ``backend: hardware`` rig description.
    behind
        The bench the simulators look at.

    Returns
    -------
    SimulatedRig
        ``.rig`` is the rig; ``.close()`` stops everything (also called at exit).

    Raises
    ------
    DeviceError
        When the virtual display cannot start here (naming what to install).
    """
    from sassi_bench.rig.hardware.simulators.display import DummyXServer
    from sassi_bench.rig.hardware.simulators.simavr_trigger import trigger_simulator
    from sassi_bench.rig.hardware.slm_display import DisplaySlm
    from sassi_bench.rig.hardware.trigger import ArduinoTrigger

    reason = simulation_missing()
    if reason:
        raise DeviceError(
            step_error(
                "simulated rig",
                reason,
                "install what it names (.ci/run lists the system packages), or run on the "
                "virtual bench alone with --rig sim",
            )
        )
    hw = desc.hardware or {}
    sim = SimulatedRig(Path(tempfile.mkdtemp(prefix="sassi-bench-simulated-")))
    try:
        sim.display = DummyXServer(sim.workdir, (desc.slm.width, desc.slm.height))
        sim.on_close(sim.display.close)
        os.environ["DISPLAY"] = sim.display.display
        # The simulated monitor is an X server: Qt must draw through X even where the
        # desktop asks for Wayland or an offscreen platform.
        os.environ["QT_QPA_PLATFORM"] = "xcb"
        sim.trigger, trigger_runs = trigger_simulator(sim.workdir)
        sim.on_close(sim.trigger.close)
        options = {k: v for k, v in hw["trigger"].items() if k not in ("kind", "port")}
        options["boot_s"] = min(float(options.get("boot_s", 3.0)), 2.0)
        trigger = ArduinoTrigger(str(sim.trigger.link), **options)
        sim.on_close(trigger.close)
        slm = DisplaySlm(
            (desc.slm.height, desc.slm.width), monitor="DUMMY1", on_display=sim.trigger.pulse
        )
        sim.on_close(slm.close)
        light = _OperatorLight(desc, behind)
        shown: list[int | None] = [None]

        def displayed() -> None:
            """Hand the bench what the SLM window displays, grabbed from the server."""
            if slm.pattern_id == shown[0]:
                return
            expected = slm.current_pattern()
            deadline = time.monotonic() + _READBACK_S
            pixels = sim.display.grab_slm()
            while not np.array_equal(pixels, expected) and time.monotonic() < deadline:
                time.sleep(0.005)
                pixels = sim.display.grab_slm()
            sim.readbacks += 1
            sim.stale_readbacks += not np.array_equal(pixels, expected)
            behind.show(pixels)
            shown[0] = slm.pattern_id

        def state() -> tuple[int | None, str]:
            return slm.pattern_id, light.current

        def spectral(exposure_s: float) -> NDArray[Any]:
            displayed()
            return behind.spectral(exposure_s)

        def guide(exposure_s: float) -> NDArray[Any]:
            displayed()
            return behind.guide(exposure_s)

        cameras = {}
        for name, render, shape, bits, described in (
            ("spectral", spectral, behind.spectral_shape, behind.spectral_bits,
             desc.spectral_camera),
            ("guide", guide, behind.guide_shape, behind.guide_bits, desc.guide_camera),
        ):  # fmt: skip
            camera = _camera(
                name,
                hw[f"{name}_camera"],
                render,
                shape,
                bits,
                tuple(described.exposure_range_s),
                sim.trigger.pulse,
                state,
            )
            sim.on_close(camera.close)
            cameras[name] = camera
        sim.rig = Rig(
            description=desc,
            slm=slm,
            spectral_camera=cameras["spectral"],
            guide_camera=cameras["guide"],
            light=light,
            trigger=trigger,
            scene_setter=behind.set_scene,
            scene=None,
            simulated_by={"trigger": trigger_runs},
        )
    except BaseException:
        sim.close()
        raise
    return sim
