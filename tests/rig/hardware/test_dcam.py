"""DCAM adapter: the missing vendor runtime is explained; the trigger logic runs on a
fake camera (``test_contract.py`` holds the adapter to the camera contract)."""

import sys

import numpy as np
import pytest

from sassi_bench.errors import DeviceError
from sassi_bench.rig.hardware.dcam import DcamCamera, open_dcam

FakeDcam = sys.modules["sassi_bench_test_fake_dcam"].FakeDcam  # loaded by tests/rig/conftest.py


def test_missing_runtime_says_what_to_install():
    pytest.importorskip("pylablib")
    with pytest.raises(
        DeviceError, match=r"(?s)cannot open Hamamatsu camera 0 .*Fix: install Hamamatsu's DCAM-API"
    ):
        open_dcam("spectral")


@pytest.mark.parametrize(
    ("trigger", "mode"), [("line", "ext"), ("software", "software"), ("none", "int")]
)
def test_trigger_modes_exposure_and_frames(trigger, mode):
    device = FakeDcam()
    camera = DcamCamera("spectral", device, trigger=trigger, exposure_range_s=(1e-4, 2.0))
    assert device.trigger_mode == mode
    assert camera.exposure_range_s == (1e-4, 2.0) and camera.shape == (8, 12)
    camera.set_exposure(0.5)
    assert device.exposure == 0.5
    frames = [camera.capture(), camera.capture()]
    assert [int(f.data[0, 0]) for f in frames] == [1, 2] and frames[0].data.dtype == np.uint16
    assert device.software_triggers == (2 if trigger == "software" else 0)
    expected_wait = {"line": [("now", 2)] * 2, "software": [("lastread", 1)] * 2, "none": []}
    assert device.waits == expected_wait[trigger]  # line: skip frames from before the call
    assert device.acquiring == (trigger != "none")
    camera.close()
    assert device.closed and not device.acquiring


def test_unknown_trigger():
    with pytest.raises(DeviceError, match="unknown trigger 'ttl'"):
        DcamCamera("spectral", FakeDcam(), trigger="ttl")
