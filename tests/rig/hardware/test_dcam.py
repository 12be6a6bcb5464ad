"""DCAM adapter: the missing vendor runtime is explained; the logic runs on a fake camera."""

from types import SimpleNamespace

import numpy as np
import pytest

from sassi_bench.errors import DeviceError
from sassi_bench.rig.hardware.dcam import DcamCamera, open_dcam


class FakeDcam:
    """The part of pylablib's DCAMCamera the adapter uses."""

    def __init__(self):
        self.trigger_mode = None
        self.exposure = 0.01
        self.acquiring = False
        self.software_triggers = 0
        self.frames = 0
        self.closed = False
        self.waits = []

    def set_trigger_mode(self, mode):
        self.trigger_mode = mode

    def get_attribute(self, name):
        assert name == "EXPOSURE TIME"
        return SimpleNamespace(min=3.8e-5, max=10.0)

    def get_data_dimensions(self):
        return (8, 12)

    def get_exposure(self):
        return self.exposure

    def set_exposure(self, seconds):
        self.exposure = seconds

    def _frame(self):
        self.frames += 1
        return np.full((8, 12), self.frames, dtype=np.uint16)

    def snap(self, timeout):
        return self._frame()

    def acquisition_in_progress(self):
        return self.acquiring

    def setup_acquisition(self, mode, nframes):
        pass

    def start_acquisition(self):
        self.acquiring = True

    def stop_acquisition(self):
        self.acquiring = False

    def send_software_trigger(self):
        self.software_triggers += 1

    def wait_for_frame(self, since, nframes, timeout):
        self.waits.append((since, nframes))

    def read_newest_image(self):
        return self._frame()

    def close(self):
        self.closed = True


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
    with pytest.raises(ValueError, match="outside the camera's range"):
        camera.set_exposure(5.0)
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
