"""GenICam cameras (FLIR Blackfly and most machine-vision cameras) through harvesters.

A GenTL producer (the vendor's ``.cti`` file, e.g. FLIR Spinnaker's
``FLIR_GenTL.cti``) exposes the camera; harvesters opens it and its GenApi node map
holds the SFNC features used here: ``Width``, ``Height``, ``PixelFormat``,
``ExposureTime`` (microseconds; ``ExposureTimeAbs`` on older GigE cameras) and the
``Trigger*`` group. Frames are taken three ways:

- ``trigger="line"``: ``FrameStart`` on a hardware line (``trigger_line``, wired to
  the trigger Arduino), rising edge. The SLM pulses with every displayed frame, so
  frames pile up between captures: a capture drops the buffered ones and
  ``settle_frames`` more (an exposure may have begun before the call), then returns
  the next;
- ``trigger="software"``: ``TriggerSoftware`` per capture, so a frame never predates
  the call;
- ``trigger="none"``: cameras without trigger features; acquisition is started and
  stopped around each capture, so no stale buffered frame is returned.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import DeviceError, step_error
from sassi_bench.rig.base import CameraBase, Exposure
from sassi_bench.rig.cameras import CAMERA_KINDS
from sassi_bench.rig.hardware import require

__all__ = ["PIXEL_FORMATS", "GenICamCamera", "frame_from_component", "open_genicam"]

# pixel format -> (bit depth, channels kept, channel order reversed)
PIXEL_FORMATS: dict[str, tuple[int, int, bool]] = {
    "Mono8": (8, 1, False),
    "Mono10": (10, 1, False),
    "Mono12": (12, 1, False),
    "Mono14": (14, 1, False),
    "Mono16": (16, 1, False),
    "RGB8": (8, 3, False),
    "BGR8": (8, 3, True),
    "RGBa8": (8, 3, False),
    "BGRa8": (8, 3, True),
}

State = Callable[[], tuple[int | None, str]]


def _no_state() -> tuple[int | None, str]:
    return None, "unknown"


def frame_from_component(
    data: NDArray[Any], height: int, width: int, pixel_format: str
) -> NDArray[Any]:
    """Reshape a GenTL buffer component into (height, width) or (height, width, 3).

    Alpha is dropped and BGR reordered to RGB; the result is a copy (the buffer goes
    back to the producer).

    Examples
    --------
    >>> raw = np.arange(2 * 3 * 4, dtype=np.uint8)
    >>> frame_from_component(raw, 2, 3, "BGRa8")[0, 0].tolist()
    [2, 1, 0]
    >>> frame_from_component(np.arange(6, dtype=np.uint16), 2, 3, "Mono12").shape
    (2, 3)
    """
    if pixel_format not in PIXEL_FORMATS:
        raise DeviceError(
            step_error(
                "GenICam capture",
                f"pixel format {pixel_format!r} is not supported",
                f"set the camera's pixel_format to one of {', '.join(PIXEL_FORMATS)}",
            )
        )
    _, channels, reverse = PIXEL_FORMATS[pixel_format]
    per_pixel = data.size // (height * width)
    if per_pixel * height * width != data.size:
        raise DeviceError(
            step_error(
                "GenICam capture",
                f"buffer of {data.size} values does not fit {height}x{width} pixels",
                "check the producer reports the pixel format it sends",
            )
        )
    image = data.reshape(height, width, per_pixel)[..., :channels]
    if reverse:
        image = image[..., ::-1]
    if channels == 1:
        image = image[..., 0]
    return np.ascontiguousarray(image)


@CAMERA_KINDS.register("genicam")
class GenICamCamera(CameraBase):
    """A camera behind a harvesters ``ImageAcquirer``.

    Parameters
    ----------
    name
        Camera name in frame metadata (``"guide"``, ``"spectral"``).
    acquirer
        A harvesters ``ImageAcquirer`` (see :func:`open_genicam`).
    node_map
        The GenApi node map to configure; defaults to the acquirer's remote device's.
    pixel_format
        Set ``PixelFormat`` to this (``"Mono16"``, ``"RGB8"`` ...); None keeps the
        camera's.
    trigger
        ``"line"``, ``"software"``, ``"none"`` or ``"auto"`` (software when the camera
        has ``TriggerSoftware``, else none).
    trigger_line
        The input line wired to the trigger Arduino (``"Line0"``), for ``"line"``.
    exposure_range_s
        Limits tighter than the camera's; None uses the ``ExposureTime`` node's.
    timeout_s
        How long a capture waits for a frame.
    settle_frames
        Line trigger only: frames dropped after the buffered ones (see above).
    state
        Returns (SLM pattern id, light name) for frame metadata.

    Cameras without ``ExposureTime`` keep the exposure set in the vendor's tool:
    give it as ``exposure_range_s`` (both values equal) so frames record it;
    otherwise it is recorded as 0.

    Examples
    --------
    Not run here (it needs the hardware)::

        cam = open_genicam("guide", "/opt/spinnaker/lib/FLIR_GenTL.cti",
                           device={"serial_number": "20123456"}, pixel_format="RGB8")
        cam.capture().shape
        # (1080, 1440, 3)
    """

    #: A rig's ``hardware`` section may name it.
    hardware = True

    @classmethod
    def open(cls, name: str, options: dict[str, Any], context: State) -> GenICamCamera:
        """Open the camera a ``hardware.<camera>`` section of kind ``genicam`` describes
        (:func:`open_genicam`; ``context`` gives each frame's SLM pattern and light)."""
        options = dict(options)
        cti = options.pop("cti")
        device = options.pop("device", 0)
        return open_genicam(name, cti, device, state=context, **options)

    def __init__(
        self,
        name: str,
        acquirer: Any,
        *,
        node_map: Any = None,
        pixel_format: str | None = None,
        trigger: str = "auto",
        trigger_line: str = "Line0",
        exposure_range_s: Sequence[float] | None = None,
        timeout_s: float = 5.0,
        settle_frames: int = 1,
        state: State | None = None,
        on_close: Callable[[], None] | None = None,
    ) -> None:
        self._ia = acquirer
        self._settle = int(settle_frames)
        self._nm = node_map if node_map is not None else acquirer.remote_device.node_map
        self._timeout = float(timeout_s)
        self._state = state or _no_state
        self._on_close = on_close
        self._streaming = False
        self._label = name
        if pixel_format is not None:
            self._set_enum("PixelFormat", pixel_format)
        fmt = str(self._node("PixelFormat", required=True).value)
        if fmt not in PIXEL_FORMATS:
            raise DeviceError(
                step_error(
                    f"{name} camera",
                    f"pixel format {fmt!r} is not supported",
                    f"set pixel_format to one of {', '.join(PIXEL_FORMATS)} in the rig YAML",
                )
            )
        self.pixel_format = fmt
        bits, channels, _ = PIXEL_FORMATS[fmt]
        height = int(self._node("Height", required=True).value)
        width = int(self._node("Width", required=True).value)
        shape = (height, width) if channels == 1 else (height, width, 3)
        self._exposure_node = self._node("ExposureTime") or self._node("ExposureTimeAbs")
        if self._exposure_node is not None:
            self._set_enum("ExposureAuto", "Off", optional=True)
            self._set_enum("ExposureMode", "Timed", optional=True)
            lo = float(self._exposure_node.min) / 1e6
            hi = float(self._exposure_node.max) / 1e6
            current = float(self._exposure_node.value) / 1e6
        elif exposure_range_s is None:
            lo = hi = current = 0.0
        else:
            lo = hi = current = float(exposure_range_s[0])
        if exposure_range_s is not None and self._exposure_node is not None:
            lo, hi = max(lo, float(exposure_range_s[0])), min(hi, float(exposure_range_s[1]))
        super().__init__(name, shape, bits, (lo, hi), min(max(current, lo), hi))
        self.trigger = self._configure_trigger(trigger, trigger_line)

    # -- node map helpers -------------------------------------------------------

    def _node(self, feature: str, required: bool = False) -> Any:
        try:
            node = getattr(self._nm, feature)
        except Exception:  # harvesters/genicam raise their own types for absent nodes
            node = None
        if node is None and required:
            raise DeviceError(
                step_error(
                    f"{self._label} camera",
                    f"the camera has no {feature} feature",
                    "use a GenICam (SFNC) camera and its vendor's GenTL producer",
                )
            )
        return node

    def _set_enum(self, feature: str, value: str, optional: bool = False) -> bool:
        node = self._node(feature, required=not optional)
        if node is None:
            return False
        symbolics = tuple(getattr(node, "symbolics", ()) or ())
        if symbolics and value not in symbolics:
            if optional:
                return False
            raise DeviceError(
                step_error(
                    f"{self._label} camera",
                    f"{feature} cannot be {value!r}",
                    f"use one of {', '.join(symbolics)}",
                )
            )
        try:
            node.value = value
        except Exception as exc:
            if optional:
                return False
            raise DeviceError(
                step_error(
                    f"{self._label} camera",
                    f"setting {feature} to {value!r} failed ({exc})",
                    "stop other programs using the camera (e.g. SpinView) and retry",
                )
            ) from exc
        return True

    def _configure_trigger(self, trigger: str, line: str) -> str:
        has_trigger = self._node("TriggerMode") is not None
        if trigger == "auto":
            trigger = "software" if self._node("TriggerSoftware") is not None else "none"
        if trigger not in ("line", "software", "none"):
            raise DeviceError(
                step_error(
                    f"{self._label} camera",
                    f"unknown trigger {trigger!r}",
                    "use line, software, none or auto",
                )
            )
        if trigger == "none":
            if has_trigger:
                self._set_enum("TriggerMode", "Off")
            return trigger
        if not has_trigger:
            raise DeviceError(
                step_error(
                    f"{self._label} camera",
                    f"trigger {trigger!r} needs TriggerMode, which the camera lacks",
                    "set trigger: none for this camera",
                )
            )
        self._set_enum("TriggerMode", "Off")  # some cameras lock the selector while on
        self._set_enum("TriggerSelector", "FrameStart", optional=True)
        if trigger == "line":
            self._set_enum("TriggerSource", line)
            self._set_enum("TriggerActivation", "RisingEdge", optional=True)
        else:
            self._set_enum("TriggerSource", "Software")
        self._set_enum("TriggerMode", "On")
        return trigger

    # -- Camera hooks -----------------------------------------------------------

    def _set_exposure(self, seconds: float) -> None:
        if self._exposure_node is None:
            return  # fixed exposure: the range check already allowed only that value
        self._exposure_node.value = seconds * 1e6

    def _fetch(self) -> NDArray[Any]:
        try:
            with self._ia.fetch(timeout=self._timeout) as buffer:
                component = buffer.payload.components[0]
                return frame_from_component(
                    component.data, component.height, component.width, self.pixel_format
                )
        except DeviceError:
            raise
        except Exception as exc:  # harvesters raises its own timeout types
            fix = (
                "check the trigger cable to the camera's input line and that the trigger is armed"
                if self.trigger == "line"
                else "check the camera's connection and exposure"
            )
            raise DeviceError(
                step_error(
                    f"{self.name} camera capture",
                    f"no frame within {self._timeout:g} s ({exc})",
                    fix,
                )
            ) from exc

    def _drain(self) -> None:
        """Give back every frame already buffered (exposed before this capture)."""
        while (buffer := self._ia.try_fetch(timeout=0.0)) is not None:
            buffer.queue()

    def _expose(self) -> Exposure:
        pattern_id, light = self._state()
        if self.trigger == "none":
            self._ia.start()
            try:
                data = self._fetch()
            finally:
                self._ia.stop()
        else:
            if not self._streaming:
                self._ia.start()
                self._streaming = True
            self._drain()
            if self.trigger == "software":
                self._node("TriggerSoftware", required=True).execute()
            else:
                for _ in range(self._settle):
                    self._fetch()
            data = self._fetch()
        return Exposure(data, pattern_id, light, {"pixel_format": self.pixel_format})

    def close(self) -> None:
        """Stop streaming and release the camera."""
        if self._streaming:
            self._ia.stop()
            self._streaming = False
        self._ia.destroy()
        if self._on_close is not None:
            self._on_close()


def open_genicam(
    name: str,
    cti: str | Sequence[str],
    device: int | dict[str, str] = 0,
    **kwargs: Any,
) -> GenICamCamera:
    """Open a GenICam camera through its GenTL producer(s).

    Parameters
    ----------
    name
        Camera name in frame metadata.
    cti
        Path(s) of the GenTL producer ``.cti`` file(s).
    device
        Index in the discovered list, or a selector such as
        ``{"serial_number": "20123456"}`` (also ``model``, ``id_``, ``vendor``).
    **kwargs
        Passed to :class:`GenICamCamera`.

    Raises
    ------
    DeviceError
        When harvesters is missing, a producer file does not exist, no camera is
        found or the selector matches none.
    """
    files = [cti] if isinstance(cti, str) else list(cti)
    for path in files:
        if not Path(path).is_file():
            raise DeviceError(
                step_error(
                    f"{name} camera",
                    f"GenTL producer {path!r} does not exist",
                    "install the camera vendor's SDK (e.g. FLIR Spinnaker) and set cti to its "
                    ".cti file",
                )
            )
    harvester, release = _shared_harvester(name, tuple(str(p) for p in files))
    infos = list(harvester.device_info_list)
    found = ", ".join(
        f"{i}: {getattr(d, 'model', '?')} serial {getattr(d, 'serial_number', '?')}"
        for i, d in enumerate(infos)
    )
    if not infos:
        release()
        raise DeviceError(
            step_error(
                f"{name} camera",
                f"no camera found by {', '.join(files)}",
                "connect and power the camera; for GigE cameras check the network adapter's "
                "address and MTU",
            )
        )
    try:
        acquirer = harvester.create(device)
    except Exception as exc:
        release()
        raise DeviceError(
            step_error(
                f"{name} camera",
                f"no camera matches {device!r} ({exc})",
                f"choose one of: {found}",
            )
        ) from exc
    try:
        return GenICamCamera(name, acquirer, on_close=release, **kwargs)
    except BaseException:
        acquirer.destroy()  # release the camera for the next attempt
        release()
        raise


# One Harvester per set of producers: a producer is loaded once per process, and a
# second Harvester on it sees no cameras (two Blackflys on Spinnaker share one).
_HARVESTERS: dict[tuple[str, ...], list[Any]] = {}


def _shared_harvester(name: str, files: tuple[str, ...]) -> tuple[Any, Callable[[], None]]:
    """The process's Harvester for ``files`` and a function that releases one use."""
    if files not in _HARVESTERS:
        core = require("harvesters.core", "harvesters", f"{name} camera")
        harvester = core.Harvester()
        for path in files:
            harvester.add_file(path)
        harvester.update()
        _HARVESTERS[files] = [harvester, 0]
    entry = _HARVESTERS[files]
    entry[1] += 1

    def release() -> None:
        entry[1] -= 1
        if entry[1] == 0 and _HARVESTERS.get(files) is entry:
            del _HARVESTERS[files]
            entry[0].reset()

    return entry[0], release
