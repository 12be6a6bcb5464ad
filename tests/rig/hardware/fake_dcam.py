"""A stand-in for pylablib's DCAMCamera: the part of it the DCAM adapter uses."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np


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
