"""The contract every device backend must honour.

Each backend registers a factory in BACKENDS that returns a Rig; the hardware
adapters run against simulators of their devices (``hardware_rig`` in conftest.py:
the trigger firmware in simavr, the SLM window on a dummy X server, the GenTL
producer of the genicam wheel) and skip with the reason where those are missing.
The tests use only the protocols, never backend internals.
"""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.rig import Camera, Frame, LightSource, Slm, Trigger

BACKENDS = {
    "sim": lambda request: open_rig("sim"),
    "hardware": lambda request: request.getfixturevalue("hardware_rig"),
}


@pytest.fixture(scope="module", params=sorted(BACKENDS))
def rig(request):
    return BACKENDS[request.param](request)


def test_devices_implement_the_protocols(rig):
    assert isinstance(rig.slm, Slm)
    assert isinstance(rig.spectral_camera, Camera)
    assert isinstance(rig.guide_camera, Camera)
    assert isinstance(rig.light, LightSource)
    assert isinstance(rig.trigger, Trigger)


def test_slm_accepts_bool_and_uint8_and_counts_patterns(rig):
    shape = rig.slm.shape
    first = rig.slm.show(np.zeros(shape, dtype=bool))
    second = rig.slm.show(np.full(shape, 128, dtype=np.uint8))
    assert second == first + 1 == rig.slm.pattern_id
    shown = rig.slm.current_pattern()
    assert shown.dtype == np.uint8 and np.all(shown == 128)
    shown[:] = 0  # a copy: the device's pattern is untouched
    assert np.all(rig.slm.current_pattern() == 128)


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda s: np.zeros((s[0] + 1, s[1]), bool), r"SLM show: pattern has shape"),
        (lambda s: np.zeros(s[::-1], bool) if s[0] != s[1] else np.zeros((1, 1), bool), "shape"),
        (lambda s: np.zeros(s, np.float32), r"dtype is float32, expected bool or uint8"),
        (lambda s: np.zeros(s, np.uint16), r"dtype is uint16"),
        (lambda s: np.zeros(s[0], bool), "shape"),
    ],
)
def test_slm_rejects_bad_patterns_with_clear_errors(rig, make, match):
    before = rig.slm.pattern_id
    with pytest.raises(ValueError, match=match):
        rig.slm.show(make(rig.slm.shape))
    assert rig.slm.pattern_id == before


@pytest.mark.parametrize("camera_name", ["spectral_camera", "guide_camera"])
def test_camera_exposure_range_is_enforced(rig, camera_name):
    camera = getattr(rig, camera_name)
    lo, hi = camera.exposure_range_s
    camera.set_exposure(lo)
    assert camera.exposure_s == lo
    for bad in (hi * 2, lo / 2, -1.0, float("nan"), "fast"):
        with pytest.raises(ValueError, match=r"exposure: .* outside the camera's range"):
            camera.set_exposure(bad)
    assert camera.exposure_s == lo
    camera.set_exposure(min(0.01, hi))


@pytest.mark.parametrize("camera_name", ["spectral_camera", "guide_camera"])
def test_capture_returns_a_read_only_frame_with_metadata(rig, camera_name):
    camera = getattr(rig, camera_name)
    rig.light.select("off")
    pid = rig.slm.show(np.zeros(rig.slm.shape, bool))
    camera.set_exposure(0.001)
    first = camera.capture()
    second = camera.capture()
    assert isinstance(first, Frame)
    assert first.shape == camera.shape
    assert first.data.dtype.kind == "u"
    assert first.data.max() < 2**camera.bit_depth
    assert first.meta.exposure_s == 0.001
    assert first.meta.light == "off"
    assert first.meta.pattern_id == pid
    assert second.meta.index == first.meta.index + 1
    assert second.meta.timestamp >= first.meta.timestamp
    with pytest.raises(ValueError):
        first.data[0, 0] = 1


def test_light_selection(rig):
    assert "off" in rig.light.available
    lasers = [name for name in rig.light.available if name.startswith("laser:")]
    assert lasers
    rig.light.select(lasers[0].upper())
    assert rig.light.current == lasers[0]
    nm = float(lasers[0][6:])
    rig.light.select(f"laser:{nm:.1f}")
    assert rig.light.current == lasers[0]
    with pytest.raises(ValueError, match=r"light select: 'laser:123' is not a light of this rig"):
        rig.light.select("laser:123")
    assert rig.light.current == lasers[0]
    rig.light.select("off")


def test_trigger_divider_and_counters(rig):
    trigger = rig.trigger
    for bad in (0, -1, 1.5, True, "2", 70000):
        with pytest.raises(ValueError, match="trigger divider"):
            trigger.set_divider(bad)
    trigger.set_divider(2)
    assert trigger.divider == 2
    trigger.arm()
    assert trigger.armed
    before = trigger.counters()
    for _ in range(4):
        rig.slm.show(np.zeros(rig.slm.shape, bool))
    after = trigger.counters()
    assert after["received"] - before["received"] == 4
    assert after["passed"] - before["passed"] == 2
    trigger.disarm()
    rig.slm.show(np.zeros(rig.slm.shape, bool))
    rig.slm.show(np.zeros(rig.slm.shape, bool))
    assert trigger.counters()["passed"] == after["passed"]
    trigger.set_divider(1)


def test_unknown_scene_is_rejected(rig):
    with pytest.raises(ValueError, match="unknown scene"):
        rig.set_scene("moon")
