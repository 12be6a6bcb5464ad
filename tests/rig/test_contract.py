"""The contract every device backend honours, one suite per device type.

As in python-microscope's test suite, a mixin per device type (``SlmContract``,
``CameraContract``, ``LightSourceContract``, ``TriggerContract``, and ``RigContract``
for a whole rig) holds tests that use the protocol only; one test class per concrete
device mixes in its type's contract and provides the device as a fixture. The hardware
adapters run against simulators or fakes of their devices (``conftest.py``: the
trigger firmware in simavr and a pty fake of it, the SLM window on a dummy X server,
the GenTL producer of the genicam wheel, a fake pylablib DCAM camera) and skip with
the reason where those are missing.
"""

from __future__ import annotations

import sys

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.rig import Camera, Frame, LightSource, Slm, Trigger
from sassi_bench.rig.base import SlmBase
from sassi_bench.rig.hardware.dcam import DcamCamera
from sassi_bench.rig.hardware.genicam import GenICamCamera
from sassi_bench.rig.hardware.manual import ManualLight
from sassi_bench.rig.hardware.trigger import ArduinoTrigger

fake_genicam = sys.modules["sassi_bench_test_fake_genicam"]  # loaded by tests/rig/conftest.py
fake_dcam = sys.modules["sassi_bench_test_fake_dcam"]


class StandInSlm(SlmBase):
    """A checked SLM that displays nothing: the pattern state a lone camera reports."""

    def _display(self, pattern: np.ndarray) -> None:
        pass


def operator_light() -> ManualLight:
    """Lights switched by an operator who obeys at once."""
    return ManualLight((450.0, 532.0), prompt=lambda message: None)


def transposed(shape):
    return np.zeros(shape[::-1], bool) if shape[0] != shape[1] else np.zeros((1, 1), bool)


# Patterns an SLM must refuse (made for its shape), and what the error says.
BAD_PATTERNS = [
    pytest.param(
        lambda s: np.zeros((s[0] + 1, s[1]), bool), r"SLM show: pattern has shape", id="tall"
    ),
    pytest.param(transposed, "shape", id="transposed"),
    pytest.param(
        lambda s: np.zeros(s, np.float32), r"dtype is float32, expected bool or uint8", id="float"
    ),
    pytest.param(lambda s: np.zeros(s, np.uint16), r"dtype is uint16", id="uint16"),
    pytest.param(lambda s: np.zeros(s[0], bool), "shape", id="1-D"),
]


# -- the contracts --------------------------------------------------------------------
class SlmContract:
    """Needs a fixture ``slm``."""

    def test_implements_the_protocol(self, slm):
        assert isinstance(slm, Slm)

    def test_accepts_bool_and_uint8_and_counts_patterns(self, slm):
        shape = slm.shape
        first = slm.show(np.zeros(shape, dtype=bool))
        second = slm.show(np.full(shape, 128, dtype=np.uint8))
        assert second == first + 1 == slm.pattern_id
        shown = slm.current_pattern()
        assert shown.dtype == np.uint8 and np.all(shown == 128)
        shown[:] = 0  # a copy: the device's pattern is untouched
        assert np.all(slm.current_pattern() == 128)

    @pytest.mark.parametrize(("make", "match"), BAD_PATTERNS)
    def test_rejects_bad_patterns_with_clear_errors(self, slm, make, match):
        before = slm.pattern_id
        with pytest.raises(ValueError, match=match):
            slm.show(make(slm.shape))
        assert slm.pattern_id == before


class CameraContract:
    """Needs a fixture ``camera`` whose frames report the state of the fixtures ``slm``
    and ``light``: by default checked stand-ins (a camera of a rig uses the rig's)."""

    @pytest.fixture(scope="class")
    @classmethod
    def slm(cls):
        return StandInSlm((4, 6))

    @pytest.fixture(scope="class")
    @classmethod
    def light(cls):
        return operator_light()

    def test_implements_the_protocol(self, camera):
        assert isinstance(camera, Camera)

    def test_exposure_range_is_enforced(self, camera):
        lo, hi = camera.exposure_range_s
        camera.set_exposure(lo)
        assert camera.exposure_s == lo
        for bad in (hi * 2, lo / 2, -1.0, float("nan"), "fast"):
            with pytest.raises(ValueError, match=r"exposure: .* outside the camera's range"):
                camera.set_exposure(bad)
        assert camera.exposure_s == lo
        camera.set_exposure(min(0.01, hi))

    def test_capture_returns_a_read_only_frame_with_metadata(self, camera, slm, light):
        light.select("off")
        pid = slm.show(np.zeros(slm.shape, bool))
        camera.set_exposure(0.001)
        first = camera.capture()
        second = camera.capture()
        assert isinstance(first, Frame)
        assert first.shape == camera.shape
        assert first.data.dtype.kind == "u"
        assert first.data.max() < 2**camera.bit_depth
        assert first.meta.camera == camera.name
        assert first.meta.exposure_s == 0.001
        assert first.meta.light == "off"
        assert first.meta.pattern_id == pid
        assert second.meta.index == first.meta.index + 1
        assert second.meta.timestamp >= first.meta.timestamp
        with pytest.raises(ValueError):
            first.data[0, 0] = 1


class LightSourceContract:
    """Needs a fixture ``light`` with at least one laser."""

    def test_implements_the_protocol(self, light):
        assert isinstance(light, LightSource)

    def test_selection_normalises_names_and_refuses_unknown_lights(self, light):
        assert "off" in light.available
        lasers = [name for name in light.available if name.startswith("laser:")]
        assert lasers
        light.select(lasers[0].upper())
        assert light.current == lasers[0]
        nm = float(lasers[0][6:])
        light.select(f"laser:{nm:.1f}")
        assert light.current == lasers[0]
        with pytest.raises(ValueError, match=r"light select: 'laser:123' is not a light of"):
            light.select("laser:123")
        assert light.current == lasers[0]
        light.select("off")


class TriggerContract:
    """Needs fixtures ``trigger`` and ``pulse`` (sends it one SLM master pulse)."""

    def test_implements_the_protocol(self, trigger):
        assert isinstance(trigger, Trigger)

    def test_divider_and_counters(self, trigger, pulse):
        for bad in (0, -1, 1.5, True, "2", 70000):
            with pytest.raises(ValueError, match="trigger divider"):
                trigger.set_divider(bad)
        trigger.set_divider(2)
        assert trigger.divider == 2
        trigger.arm()
        assert trigger.armed
        before = trigger.counters()
        for _ in range(4):
            pulse()
        after = trigger.counters()
        assert after["received"] - before["received"] == 4
        assert after["passed"] - before["passed"] == 2
        trigger.disarm()
        assert not trigger.armed
        pulse()
        pulse()
        assert trigger.counters()["passed"] == after["passed"]
        trigger.set_divider(1)


class RigContract:
    """Needs a fixture ``rig``; its devices are held to their contracts separately."""

    def test_devices_implement_the_protocols(self, rig):
        assert isinstance(rig.slm, Slm)
        assert isinstance(rig.spectral_camera, Camera)
        assert isinstance(rig.guide_camera, Camera)
        assert isinstance(rig.light, LightSource)
        assert isinstance(rig.trigger, Trigger)

    def test_unknown_scene_is_rejected(self, rig):
        with pytest.raises(ValueError, match="unknown scene"):
            rig.set_scene("moon")


def rig_pulse(rig):
    """A pulse as the rig's SLM sends one: by showing a pattern."""
    return lambda: rig.slm.show(np.zeros(rig.slm.shape, bool))


# -- the virtual bench ----------------------------------------------------------------
@pytest.fixture(scope="module")
def sim_rig():
    return open_rig("sim")


class TestSimRig(RigContract):
    @pytest.fixture()
    def rig(self, sim_rig):
        return sim_rig


class TestSimSlm(SlmContract):
    @pytest.fixture()
    def slm(self, sim_rig):
        return sim_rig.slm


class TestSimCamera(CameraContract):
    @pytest.fixture(params=["spectral_camera", "guide_camera"])
    def camera(self, request, sim_rig):
        return getattr(sim_rig, request.param)

    @pytest.fixture()
    def slm(self, sim_rig):
        return sim_rig.slm

    @pytest.fixture()
    def light(self, sim_rig):
        return sim_rig.light


class TestSimLight(LightSourceContract):
    @pytest.fixture()
    def light(self, sim_rig):
        return sim_rig.light


class TestSimTrigger(TriggerContract):
    @pytest.fixture()
    def trigger(self, sim_rig):
        return sim_rig.trigger

    @pytest.fixture()
    def pulse(self, sim_rig):
        return rig_pulse(sim_rig)


# -- the hardware adapters, each on a simulator or fake of its device -------------------
class TestDisplaySlm(SlmContract):
    @pytest.fixture(scope="class")
    @classmethod
    def slm(cls, dummy_x):
        from sassi_bench.rig.hardware.slm_display import DisplaySlm

        device = DisplaySlm((400, 640), monitor="DUMMY1")
        yield device
        device.close()


class TestGenICamCameraOnTheProducer(CameraContract):
    """The genicam wheel's simulated cameras, with the ExposureTime node they lack."""

    @pytest.fixture(scope="class", params=[("0", "Mono8"), ("1", "RGBa8")], ids=["Mono8", "RGBa8"])
    @classmethod
    def camera(cls, request, viky_cti, slm, light):
        from harvesters.core import Harvester

        serial, pixel_format = request.param
        harvester = Harvester()
        harvester.add_file(viky_cti)
        harvester.update()
        acquirer = harvester.create({"serial_number": serial})
        nodes = fake_genicam.LayeredNodeMap(
            acquirer.remote_device.node_map, **fake_genicam.exposure_nodes()
        )
        camera = GenICamCamera(
            "guide",
            acquirer,
            node_map=nodes,
            pixel_format=pixel_format,
            trigger="none",
            state=lambda: (slm.pattern_id, light.current),
        )
        yield camera
        camera.close()
        harvester.reset()


class TestGenICamCameraOnFakeNodes(CameraContract):
    """Exposure and trigger features the producer lacks, in each trigger mode."""

    @pytest.fixture(params=["none", "software", "line"])
    def camera(self, request, slm, light):
        nodes = fake_genicam.LayeredNodeMap(
            None,
            Width=fake_genicam.FakeNode(6),
            Height=fake_genicam.FakeNode(4),
            PixelFormat=fake_genicam.FakeNode("Mono12", symbolics=("Mono8", "Mono12")),
            **fake_genicam.exposure_nodes(),
            **fake_genicam.trigger_nodes(),
        )
        return GenICamCamera(
            "spectral",
            fake_genicam.FakeAcquirer(nodes),
            trigger=request.param,
            state=lambda: (slm.pattern_id, light.current),
        )


class TestDcamCamera(CameraContract):
    """The Hamamatsu adapter on a fake pylablib camera, in each trigger mode."""

    @pytest.fixture(params=["none", "software", "line"])
    def camera(self, request, slm, light):
        camera = DcamCamera(
            "spectral",
            fake_dcam.FakeDcam(),
            trigger=request.param,
            state=lambda: (slm.pattern_id, light.current),
        )
        yield camera
        camera.close()


class TestManualLight(LightSourceContract):
    @pytest.fixture()
    def light(self):
        return operator_light()


class TestArduinoTriggerOnTheFirmware(TriggerContract):
    """The serial driver and the firmware itself, in simavr."""

    @pytest.fixture()
    def trigger(self, simavr_trigger):
        with ArduinoTrigger(simavr_trigger.port) as device:
            yield device

    @pytest.fixture()
    def pulse(self, simavr_trigger):
        return simavr_trigger.pulse


class TestArduinoTriggerOnThePtyFake(TriggerContract):
    """The serial driver against the firmware's line protocol on a pseudo-terminal."""

    @pytest.fixture()
    def trigger(self, fake_trigger):
        with ArduinoTrigger(str(fake_trigger.link), timeout_s=0.2, boot_s=1.0) as device:
            yield device

    @pytest.fixture()
    def pulse(self, fake_trigger):
        return fake_trigger.pulse


# -- every hardware adapter wired as on a bench (conftest's hardware_rig) ----------------
class TestHardwareRig(RigContract):
    @pytest.fixture()
    def rig(self, hardware_rig):
        return hardware_rig


class TestHardwareRigCamera(CameraContract):
    """Frames report the state of the rig's own SLM window and operator light."""

    @pytest.fixture(params=["spectral_camera", "guide_camera"])
    def camera(self, request, hardware_rig):
        return getattr(hardware_rig, request.param)

    @pytest.fixture()
    def slm(self, hardware_rig):
        return hardware_rig.slm

    @pytest.fixture()
    def light(self, hardware_rig):
        return hardware_rig.light


class TestHardwareRigTrigger(TriggerContract):
    """Every pattern the SLM window shows sends a master pulse to the simulated Arduino."""

    @pytest.fixture()
    def trigger(self, hardware_rig):
        return hardware_rig.trigger

    @pytest.fixture()
    def pulse(self, hardware_rig):
        return rig_pulse(hardware_rig)


#: The camera contract's test class of every registered camera kind: a new kind adds its own.
CAMERA_CONTRACTS = {
    "bench": TestSimCamera,
    "genicam": TestGenICamCameraOnFakeNodes,
    "dcam": TestDcamCamera,
}


def test_every_camera_kind_is_held_to_the_camera_contract():
    from sassi_bench.rig.cameras import CAMERA_KINDS

    assert sorted(CAMERA_KINDS) == sorted(CAMERA_CONTRACTS)
    for kind, tests in CAMERA_CONTRACTS.items():
        assert issubclass(tests, CameraContract), kind
