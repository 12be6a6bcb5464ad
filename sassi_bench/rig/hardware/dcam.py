"""Hamamatsu sCMOS cameras (ORCA-Flash 4.0 ...) through pylablib's DCAM wrapper.

Needs Hamamatsu's DCAM-API runtime (``dcamapi.dll`` on Windows, ``libdcamapi.so``
from DCAM-API for Linux) besides pylablib. Without them, opening the camera raises a
:class:`~sassi_bench.errors.DeviceError` that says what to install.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from sassi_bench.errors import DeviceError, step_error
from sassi_bench.rig.base import CameraBase, Exposure
from sassi_bench.rig.cameras import CAMERA_KINDS
from sassi_bench.rig.hardware import require

__all__ = ["DcamCamera", "open_dcam"]

_TRIGGERS = {"line": "ext", "software": "software", "none": "int"}
_DCAM_FIX = (
    "install Hamamatsu's DCAM-API for this system (it provides dcamapi / libdcamapi.so), "
    "connect and power the camera, and close HCImage or other programs using it"
)

State = Callable[[], tuple[int | None, str]]


@CAMERA_KINDS.register("dcam")
class DcamCamera(CameraBase):
    """A Hamamatsu camera behind a ``pylablib.devices.DCAM.DCAMCamera``.

    Parameters
    ----------
    name
        Camera name in frame metadata.
    camera
        An open pylablib ``DCAMCamera`` (see :func:`open_dcam`).
    trigger
        ``"line"`` (external trigger input, from the trigger Arduino), ``"software"``
        or ``"none"`` (internal).
    bit_depth
        ADC bits (16 for the ORCA-Flash 4.0 in 16-bit mode).
    exposure_range_s
        Limits tighter than the camera's; None uses the camera's.
    timeout_s
        How long a capture waits for a frame.
    settle_frames
        Line trigger only: frames skipped after the call (an exposure may have begun
        before it); the frame returned is the next one.
    state
        Returns (SLM pattern id, light name) for frame metadata.

    Examples
    --------
    Not run here (it needs the hardware)::

        cam = open_dcam("spectral", index=0, trigger="line")
        cam.capture().shape
        # (2048, 2048)
    """

    #: A rig's ``hardware`` section may name it.
    hardware = True

    @classmethod
    def open(cls, name: str, options: dict[str, Any], context: State) -> DcamCamera:
        """Open the camera a ``hardware.<camera>`` section of kind ``dcam`` describes
        (:func:`open_dcam`; ``context`` gives each frame's SLM pattern and light)."""
        return open_dcam(name, state=context, **options)

    def __init__(
        self,
        name: str,
        camera: Any,
        *,
        trigger: str = "none",
        bit_depth: int = 16,
        exposure_range_s: Sequence[float] | None = None,
        timeout_s: float = 5.0,
        settle_frames: int = 1,
        state: State | None = None,
    ) -> None:
        if trigger not in _TRIGGERS:
            raise DeviceError(
                step_error(
                    f"{name} camera", f"unknown trigger {trigger!r}", "use line, software or none"
                )
            )
        self._cam = camera
        self._timeout = float(timeout_s)
        self._settle = int(settle_frames)
        self._state = state or (lambda: (None, "unknown"))
        self.trigger = trigger
        camera.set_trigger_mode(_TRIGGERS[trigger])
        limits = camera.get_attribute("EXPOSURE TIME")
        lo, hi = float(limits.min), float(limits.max)
        if exposure_range_s is not None:
            lo, hi = max(lo, float(exposure_range_s[0])), min(hi, float(exposure_range_s[1]))
        height, width = (int(v) for v in camera.get_data_dimensions())
        current = float(camera.get_exposure())
        super().__init__(name, (height, width), bit_depth, (lo, hi), min(max(current, lo), hi))

    def _set_exposure(self, seconds: float) -> None:
        self._cam.set_exposure(seconds)

    def _expose(self) -> Exposure:
        pattern_id, light = self._state()
        if self.trigger == "none":
            data = self._cam.snap(timeout=self._timeout)
        else:
            if not self._cam.acquisition_in_progress():
                self._cam.setup_acquisition(mode="sequence", nframes=16)
                self._cam.start_acquisition()
            # Line trigger: the SLM pulses with every displayed frame, so frames taken
            # before this call are skipped (plus settle_frames); the newest is returned.
            if self.trigger == "software":
                self._cam.send_software_trigger()
                since, count = "lastread", 1
            else:
                since, count = "now", 1 + self._settle
            try:
                self._cam.wait_for_frame(since=since, nframes=count, timeout=self._timeout)
            except Exception as exc:  # pylablib's DCAMTimeoutError
                raise DeviceError(
                    step_error(
                        f"{self.name} camera capture",
                        f"no frame within {self._timeout:g} s ({exc})",
                        "check the trigger cable to the camera's trigger input and that the "
                        "trigger is armed",
                    )
                ) from exc
            data = self._cam.read_newest_image()
        frame = np.asarray(data)
        if frame.dtype.kind != "u":
            frame = frame.astype(np.uint16)
        return Exposure(np.array(frame, copy=True), pattern_id, light)

    def close(self) -> None:
        """Stop acquisition and close the camera."""
        if self._cam.acquisition_in_progress():
            self._cam.stop_acquisition()
        self._cam.close()


def open_dcam(name: str, index: int = 0, library: str | None = None, **kwargs: Any) -> DcamCamera:
    """Open Hamamatsu camera ``index`` through pylablib.

    ``library`` is the folder or file of the DCAM-API runtime when it is not on the
    system's library path.

    Raises
    ------
    DeviceError
        When pylablib or the DCAM-API runtime is missing or no camera answers.
    """
    pylablib = require("pylablib", "pylablib", f"{name} camera")
    # pylablib refuses vendor libraries outside Windows unless told otherwise.
    pylablib.par["devices/only_windows_dlls"] = False
    if library is not None:
        pylablib.par["devices/dlls/dcamapi"] = library
    dcam = require("pylablib.devices.DCAM", "pylablib", f"{name} camera")
    try:
        camera = dcam.DCAMCamera(idx=index)
    except Exception as exc:  # OSError for a missing library, DCAMError for no camera
        raise DeviceError(
            step_error(f"{name} camera", f"cannot open Hamamatsu camera {index} ({exc})", _DCAM_FIX)
        ) from exc
    return DcamCamera(name, camera, **kwargs)
