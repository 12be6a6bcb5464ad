"""Fixtures for the hardware adapters: the trigger firmware in simavr, a pty fake of
it and a dual-head dummy X server (both shipped in ``sassi_bench.rig.hardware.simulators``)
and the GenTL producer shipped with ``genicam``; the helper modules in ``hardware/``
(fakes of GenApi nodes and of pylablib's DCAM camera) are loaded here for the tests to
share.

Each skips with the reason when its system tools are missing (``.ci/run`` installs
them).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

HELPERS = Path(__file__).with_name("hardware")


def _load(name: str):
    spec = importlib.util.spec_from_file_location(
        f"sassi_bench_test_{name}", HELPERS / f"{name}.py"
    )
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


simavr = _load("simavr_device")
fake_genicam = _load("fake_genicam")
fake_dcam = _load("fake_dcam")

SLM_SIZE = (640, 400)  # the sim rig's SLM (width, height)


@pytest.fixture(scope="session")
def simavr_build(tmp_path_factory):
    """(firmware ELF, harness executable), built once per session."""
    reason = simavr.toolchain_missing()
    if reason:
        pytest.skip(reason)
    build = tmp_path_factory.mktemp("simavr")
    return simavr.build_firmware(build), simavr.build_harness(build)


@pytest.fixture()
def simavr_trigger(simavr_build):
    """A fresh simulated Arduino running the trigger firmware."""
    firmware, harness = simavr_build
    device = simavr.SimavrDevice(harness, firmware)
    yield device
    device.close()


@pytest.fixture()
def fake_trigger(tmp_path):
    """The pty fake of the trigger firmware, behind a by-id style symlink."""
    from sassi_bench.rig.hardware.simulators.serial_trigger import TriggerSimulator

    device = TriggerSimulator(tmp_path / "ttyFAKE")
    yield device
    device.close()


@pytest.fixture(scope="session")
def dummy_x(tmp_path_factory):
    """A dummy Xorg with DUMMY0 (800x600) and the SLM monitor DUMMY1 (640x400) to its right."""
    from sassi_bench.rig.hardware.simulators import display as xserver

    reason = xserver.xorg_missing()
    if reason:
        pytest.skip(reason)
    for module in ("PySide6.QtWidgets", "screeninfo", "mss"):
        pytest.importorskip(module, reason=f"{module} missing: pip install -e '.[dev]'")
    server = xserver.DummyXServer(tmp_path_factory.mktemp("xorg"), SLM_SIZE)
    # Qt aborts the process when its xcb plugin cannot load: try it in a child first.
    probe = subprocess.run(
        [sys.executable, "-c", "from PySide6.QtWidgets import QApplication; QApplication([])"],
        env={**os.environ, "DISPLAY": server.display, "QT_QPA_PLATFORM": "xcb"},
        capture_output=True,
        text=True,
        timeout=60,
    )
    if probe.returncode != 0:
        server.close()
        pytest.skip(f"Qt cannot open a window (missing libxcb-* packages?): {probe.stderr[-300:]}")
    old = {key: os.environ.get(key) for key in ("DISPLAY", "QT_QPA_PLATFORM")}
    os.environ["DISPLAY"] = server.display
    os.environ["QT_QPA_PLATFORM"] = "xcb"  # even if another test chose Qt's offscreen platform
    from PySide6 import QtWidgets

    # A process has one Qt application, on one platform, and the SLM window reuses it: an
    # application another test left (napari's viewer draws offscreen) goes first.
    stale = QtWidgets.QApplication.instance()
    if stale is not None and stale.platformName() != "xcb":
        import shiboken6

        stale.closeAllWindows()
        shiboken6.delete(stale)
    yield server
    app = QtWidgets.QApplication.instance()
    if app is not None:
        import shiboken6

        app.closeAllWindows()
        shiboken6.delete(app)  # drop the X connection before the server goes
    for key, value in old.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value
    server.close()


@pytest.fixture(scope="session")
def viky_cti():
    """The GenTL producer that ships in the genicam wheel (three simulated cameras)."""
    genicam = pytest.importorskip("genicam", reason="genicam missing: pip install -e '.[dev]'")
    pytest.importorskip("harvesters", reason="harvesters missing: pip install -e '.[dev]'")
    cti = Path(genicam.__file__).with_name("viky.cti")
    if not cti.is_file():
        pytest.skip(f"the genicam wheel has no GenTL producer at {cti}")
    return str(cti)


@pytest.fixture(scope="module")
def hardware_rig(request, tmp_path_factory):
    """Every hardware adapter wired as on a bench, with simulators in place of devices.

    Trigger: the firmware in simavr. SLM: a window on the dummy X server's second
    monitor whose every swap sends a master pulse to the simulated Arduino, as the
    SLM does. Cameras: the genicam wheel's producer (no ExposureTime there, so a fake
    ExposureTime node is layered over its node map). Lights: an operator who obeys.
    """
    from sassi_bench.rig.config import load_rig_description
    from sassi_bench.rig.hardware.genicam import GenICamCamera
    from sassi_bench.rig.hardware.manual import ManualLight
    from sassi_bench.rig.hardware.slm_display import DisplaySlm
    from sassi_bench.rig.hardware.trigger import ArduinoTrigger
    from sassi_bench.rig.rig import Rig

    firmware, harness = request.getfixturevalue("simavr_build")
    request.getfixturevalue("dummy_x")
    cti = request.getfixturevalue("viky_cti")
    from harvesters.core import Harvester

    device = simavr.SimavrDevice(harness, firmware)
    harvester = Harvester()
    harvester.add_file(cti)
    harvester.update()
    desc = load_rig_description("sim")
    trigger = ArduinoTrigger(device.port, boot_s=5.0)
    light = ManualLight(desc.lasers_nm, prompt=lambda message: None)
    slm = DisplaySlm((desc.slm.height, desc.slm.width), "DUMMY1", on_display=device.pulse)

    def state():
        return slm.pattern_id, light.current

    cameras = []
    for name, serial, fmt in (("spectral", "0", "Mono8"), ("guide", "1", "RGBa8")):
        acquirer = harvester.create({"serial_number": serial})
        nodes = fake_genicam.LayeredNodeMap(
            acquirer.remote_device.node_map, **fake_genicam.exposure_nodes()
        )
        cameras.append(
            GenICamCamera(
                name, acquirer, node_map=nodes, pixel_format=fmt, trigger="none", state=state
            )
        )
    rig = Rig(
        description=desc,
        slm=slm,
        spectral_camera=cameras[0],
        guide_camera=cameras[1],
        light=light,
        trigger=trigger,
        scene_setter=lambda name: None,
    )
    yield rig
    for camera in cameras:
        camera.close()
    harvester.reset()
    slm.close()
    trigger.close()
    device.close()
