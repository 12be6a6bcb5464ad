"""Simulators of the camera APIs the adapters drive: a harvesters image acquirer with its
GenApi node map, and pylablib's ``DCAMCamera``.

Each takes its pixels from a frame source (``render(exposure_s)``, the virtual bench
behind a simulated rig) and, when the adapter sets a line trigger, delivers a frame only
for an SLM refresh pulse the trigger passed (``refresh()``: one pulse of the SLM's master
clock into the trigger simulator; True when the trigger passed it to the cameras). A
disarmed trigger therefore times out a line-triggered capture as on a bench. Frames go
back through the adapters' own code: GenTL buffer components reshaped by
:func:`~sassi_bench.rig.hardware.genicam.frame_from_component`, DCAM's newest image.

Examples
--------
>>> import numpy as np
>>> from sassi_bench.rig.hardware.genicam import GenICamCamera
>>> acquirer = SimulatedAcquirer(
...     lambda s: np.full((4, 6), int(s * 1e3), np.uint16), shape=(4, 6), bit_depth=16,
...     exposure_range_s=(1e-3, 1.0), refresh=lambda: True)
>>> camera = GenICamCamera("spectral", acquirer, trigger="line")
>>> camera.set_exposure(0.25)
>>> int(camera.capture().data[0, 0]), acquirer.refreshes
(250, 2)
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import contextmanager
from types import SimpleNamespace
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["SimulatedAcquirer", "SimulatedDcam", "SimulatedNode"]

Render = Callable[[float], NDArray[Any]]
Refresh = Callable[[], bool]

#: SLM refreshes a line-triggered frame waits before timing out (a 60 Hz SLM's second).
_REFRESHES_PER_S = 60


class SimulatedNode:
    """A GenApi node: ``value``, ``min``/``max`` for numbers, ``symbolics`` for enums,
    ``execute`` for commands."""

    def __init__(
        self,
        value: Any,
        *,
        min: float | None = None,
        max: float | None = None,
        symbolics: tuple[str, ...] | None = None,
        on_execute: Callable[[], None] | None = None,
    ) -> None:
        self._value = value
        self.min, self.max = min, max
        self.symbolics = tuple(symbolics) if symbolics else None
        self._on_execute = on_execute

    @property
    def value(self) -> Any:
        return self._value

    @value.setter
    def value(self, new: Any) -> None:
        if self.symbolics is not None and new not in self.symbolics:
            raise ValueError(f"{new!r} is not one of {self.symbolics}")
        if self.min is not None and not self.min <= new <= self.max:
            raise ValueError(f"{new!r} is outside [{self.min}, {self.max}]")
        self._value = new

    def execute(self) -> None:
        if self._on_execute is not None:
            self._on_execute()


def _to_bits(data: NDArray[Any], from_bits: int, to_bits: int) -> NDArray[Any]:
    """Pixel values of ``from_bits`` as a camera of ``to_bits`` gives them."""
    if to_bits >= from_bits:
        return data.astype(np.uint16 if to_bits > 8 else np.uint8)
    shifted = np.right_shift(data.astype(np.uint16), from_bits - to_bits)
    return shifted.astype(np.uint8 if to_bits <= 8 else np.uint16)


class SimulatedAcquirer:
    """A harvesters ``ImageAcquirer`` of one GenICam camera (SFNC features).

    Parameters
    ----------
    render
        The frame source: pixels for an exposure in seconds, of ``shape`` and
        ``bit_depth`` bits.
    shape
        (height, width) for a monochrome camera, (height, width, 3) for a colour one.
    bit_depth
        Bits of the rendered values; they are scaled to the pixel format's.
    exposure_range_s
        The ``ExposureTime`` node's limits.
    refresh
        One SLM refresh pulse through the trigger; True when passed to the camera.
    timeout_refreshes
        Refreshes waited per second of the adapter's timeout.
    """

    def __init__(
        self,
        render: Render,
        *,
        shape: tuple[int, ...],
        bit_depth: int,
        exposure_range_s: tuple[float, float],
        refresh: Refresh,
        timeout_refreshes: int = _REFRESHES_PER_S,
    ) -> None:
        self._render = render
        self._bits = int(bit_depth)
        self._refresh = refresh
        self._per_s = int(timeout_refreshes)
        colour = len(shape) == 3
        formats = ("RGB8", "BGR8", "RGBa8", "BGRa8") if colour else ("Mono16", "Mono8")
        lo, hi = exposure_range_s
        self._pending = 0
        self.refreshes = 0
        self.started = False
        self.destroyed = False
        self.remote_device = SimpleNamespace(node_map=SimpleNamespace())
        nodes = self.remote_device.node_map
        nodes.PixelFormat = SimulatedNode(formats[0], symbolics=formats)
        nodes.ExposureTime = SimulatedNode(min(max(0.01, lo), hi) * 1e6, min=lo * 1e6, max=hi * 1e6)
        nodes.ExposureAuto = SimulatedNode("Continuous", symbolics=("Off", "Continuous"))
        nodes.TriggerMode = SimulatedNode("Off", symbolics=("Off", "On"))
        nodes.TriggerSelector = SimulatedNode("FrameStart", symbolics=("FrameStart",))
        nodes.TriggerSource = SimulatedNode("Software", symbolics=("Software", "Line0", "Line2"))
        nodes.TriggerActivation = SimulatedNode("RisingEdge", symbolics=("RisingEdge",))
        nodes.TriggerSoftware = SimulatedNode(None, on_execute=self._software_trigger)
        self._nodes = nodes
        height, width = shape[:2]
        nodes.Height = SimulatedNode(int(height))
        nodes.Width = SimulatedNode(int(width))

    def start(self) -> None:
        self.started = True

    def stop(self) -> None:
        self.started = False

    def destroy(self) -> None:
        self.destroyed = True

    def _software_trigger(self) -> None:
        self._pending += 1

    def _line_mode(self) -> bool:
        return self._nodes.TriggerMode.value == "On" and self._nodes.TriggerSource.value != (
            "Software"
        )

    def _await_frame(self, timeout: float) -> None:
        """Wait for the event that starts the next frame, or raise ``TimeoutError``."""
        if self._nodes.TriggerMode.value != "On":
            return  # free running
        if not self._line_mode():
            if self._pending:
                self._pending -= 1
                return
            raise TimeoutError("no software trigger was sent")
        for _ in range(max(1, int(timeout * self._per_s))):
            self.refreshes += 1
            if self._refresh():
                return
        raise TimeoutError("no trigger pulse on the camera's line")

    def _component(self) -> SimpleNamespace:
        exposure_s = float(self._nodes.ExposureTime.value) / 1e6
        fmt = str(self._nodes.PixelFormat.value)
        bits = 8 if fmt.endswith("8") else 16
        data = _to_bits(self._render(exposure_s), self._bits, bits)
        if fmt.startswith("BGR"):
            data = data[..., ::-1]
        if fmt.endswith("a8"):
            alpha = np.full((*data.shape[:2], 1), 255, np.uint8)
            data = np.concatenate([data, alpha], axis=-1)
        return SimpleNamespace(
            data=np.ascontiguousarray(data).reshape(-1), height=data.shape[0], width=data.shape[1]
        )

    @contextmanager
    def fetch(self, timeout: float) -> Any:
        if not self.started:
            raise TimeoutError("acquisition is not started")
        self._await_frame(timeout)
        yield SimpleNamespace(payload=SimpleNamespace(components=[self._component()]))

    def try_fetch(self, timeout: float) -> Any:
        return None  # nothing is buffered: frames are rendered when fetched


class SimulatedDcam:
    """The part of pylablib's ``DCAMCamera`` the DCAM adapter uses.

    Parameters
    ----------
    render, shape, bit_depth, exposure_range_s, refresh, timeout_refreshes
        As for :class:`SimulatedAcquirer` (``shape`` (height, width)); the frames are
        16-bit.
    """

    def __init__(
        self,
        render: Render,
        *,
        shape: tuple[int, ...],
        bit_depth: int,
        exposure_range_s: tuple[float, float],
        refresh: Refresh,
        timeout_refreshes: int = _REFRESHES_PER_S,
    ) -> None:
        self._render = render
        self._bits = int(bit_depth)
        self._refresh = refresh
        self._per_s = int(timeout_refreshes)
        self._range = exposure_range_s
        self.exposure = min(max(0.01, exposure_range_s[0]), exposure_range_s[1])
        self.trigger_mode = "int"
        self.acquiring = False
        self.closed = False
        self.refreshes = 0
        self._shape = (int(shape[0]), int(shape[1]))

    def set_trigger_mode(self, mode: str) -> None:
        self.trigger_mode = mode

    def get_attribute(self, name: str) -> SimpleNamespace:
        if name != "EXPOSURE TIME":
            raise KeyError(name)
        return SimpleNamespace(min=self._range[0], max=self._range[1])

    def get_data_dimensions(self) -> tuple[int, int]:
        return self._shape  # type: ignore[return-value]

    def get_exposure(self) -> float:
        return self.exposure

    def set_exposure(self, seconds: float) -> None:
        self.exposure = float(seconds)

    def _frame(self) -> NDArray[np.uint16]:
        return _to_bits(self._render(self.exposure), self._bits, 16).astype(np.uint16)

    def snap(self, timeout: float) -> NDArray[np.uint16]:
        return self._frame()

    def acquisition_in_progress(self) -> bool:
        return self.acquiring

    def setup_acquisition(self, mode: str, nframes: int) -> None:
        pass

    def start_acquisition(self) -> None:
        self.acquiring = True

    def stop_acquisition(self) -> None:
        self.acquiring = False

    def send_software_trigger(self) -> None:
        pass

    def wait_for_frame(self, since: str, nframes: int, timeout: float) -> None:
        if self.trigger_mode != "ext":
            return
        passed = 0
        for _ in range(max(1, int(timeout * self._per_s)) + nframes):
            self.refreshes += 1
            passed += bool(self._refresh())
            if passed >= nframes:
                return
        raise TimeoutError("no trigger pulse on the camera's trigger input")

    def read_newest_image(self) -> NDArray[np.uint16]:
        return self._frame()

    def close(self) -> None:
        self.closed = True
