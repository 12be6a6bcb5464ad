"""Base classes that give every backend the same argument checks.

A backend subclasses these and implements the underscore hooks (``_display``,
``_expose``, ``_switch``, ...). The public methods check their arguments and raise a
``ValueError`` whose message names the step, the cause and the fix, so a bad pattern
or exposure fails identically on the virtual bench and on hardware.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.rig.frame import Frame, FrameMeta
from sassi_bench.rig.rig import check_light

__all__ = [
    "CameraBase",
    "Exposure",
    "LightSourceBase",
    "SlmBase",
    "TriggerBase",
    "check_pattern",
]


def check_pattern(pattern: ArrayLike, shape: tuple[int, int]) -> NDArray[np.uint8]:
    """Validate an SLM pattern and return it as uint8 (255 = open).

    Parameters
    ----------
    pattern
        Boolean (True = open) or uint8 array of ``shape``.
    shape
        The SLM's (height, width).

    Raises
    ------
    ValueError
        For a wrong shape, a dtype other than bool/uint8, or non-finite values.

    Examples
    --------
    >>> check_pattern(np.ones((2, 2), bool), (2, 2)).tolist()
    [[255, 255], [255, 255]]
    """
    arr = np.asarray(pattern)
    check_shape(
        arr,
        tuple(shape),
        step="SLM show",
        name="pattern",
        expected_for="the SLM (height, width)",
        fix=f"pass an array of shape {tuple(shape)}",
    )
    if arr.dtype == np.bool_:
        return arr.astype(np.uint8) * np.uint8(255)
    if arr.dtype != np.uint8:
        raise ProcedureError(
            step_error(
                "SLM show",
                f"pattern dtype is {arr.dtype}, expected bool or uint8",
                "convert with pattern.astype(np.uint8) (0 closed .. 255 open) or pass a bool mask",
            )
        )
    return np.ascontiguousarray(arr)


class SlmBase(ABC):
    """Checked :class:`~sassi_bench.rig.protocols.Slm` implementation skeleton."""

    def __init__(self, shape: tuple[int, int]) -> None:
        self._shape = (int(shape[0]), int(shape[1]))
        self._pattern = np.zeros(self._shape, dtype=np.uint8)
        self._pattern_id: int | None = None
        self._next_id = 0

    @property
    def shape(self) -> tuple[int, int]:
        return self._shape

    @property
    def pattern_id(self) -> int | None:
        return self._pattern_id

    def show(self, pattern: ArrayLike) -> int:
        checked = check_pattern(pattern, self._shape)
        self._display(checked)
        self._pattern = checked
        self._pattern.setflags(write=False)
        self._pattern_id = self._next_id
        self._next_id += 1
        return self._pattern_id

    def current_pattern(self) -> NDArray[np.uint8]:
        return self._pattern.copy()

    @abstractmethod
    def _display(self, pattern: NDArray[np.uint8]) -> None:
        """Put the checked uint8 pattern on the device."""


@dataclass(frozen=True, eq=False)
class Exposure:
    """What a camera backend read in one exposure: the result of its ``_expose`` hook.

    :meth:`CameraBase.capture` adds the exposure time, timestamp and frame index and
    returns a :class:`~sassi_bench.rig.frame.Frame`.

    Parameters
    ----------
    data
        The pixels, (height, width) or (height, width, 3), unsigned integers.
    pattern_id
        Id of the SLM pattern on display while exposing (``None`` if none was shown).
    light
        Name of the selected light (``"laser:532"``, ``"off"``, ``"unknown"`` ...).
    extra
        Backend-specific metadata (JSON-compatible), kept as ``FrameMeta.extra``.

    Examples
    --------
    >>> shot = Exposure(np.zeros((2, 3), np.uint16), pattern_id=4, light="led")
    >>> shot.pattern_id, shot.light, shot.extra
    (4, 'led', {})
    """

    data: NDArray[Any]
    pattern_id: int | None
    light: str
    extra: dict[str, Any] = field(default_factory=dict)


class CameraBase(ABC):
    """Checked :class:`~sassi_bench.rig.protocols.Camera` implementation skeleton."""

    def __init__(
        self,
        name: str,
        shape: tuple[int, ...],
        bit_depth: int,
        exposure_range_s: tuple[float, float],
        exposure_s: float,
    ) -> None:
        self.name = name
        self._shape = tuple(int(s) for s in shape)
        self._bit_depth = int(bit_depth)
        self._exposure_range = (float(exposure_range_s[0]), float(exposure_range_s[1]))
        self._exposure = float(exposure_s)
        self._index = 0

    @property
    def shape(self) -> tuple[int, ...]:
        return self._shape

    @property
    def bit_depth(self) -> int:
        return self._bit_depth

    @property
    def exposure_range_s(self) -> tuple[float, float]:
        return self._exposure_range

    @property
    def exposure_s(self) -> float:
        return self._exposure

    def set_exposure(self, seconds: float) -> None:
        lo, hi = self._exposure_range
        try:
            value = float(seconds)
        except (TypeError, ValueError):
            value = float("nan")
        if not lo <= value <= hi:
            raise ProcedureError(
                step_error(
                    f"{self.name} camera exposure",
                    f"{seconds!r} s is outside the camera's range [{lo:g}, {hi:g}] s",
                    "choose an exposure inside the range (check the units: seconds)",
                )
            )
        self._set_exposure(value)
        self._exposure = value

    def capture(self) -> Frame:
        shot = self._expose()
        meta = FrameMeta(
            camera=self.name,
            exposure_s=self._exposure,
            timestamp=time.time(),
            pattern_id=shot.pattern_id,
            light=shot.light,
            index=self._index,
            extra=shot.extra,
        )
        self._index += 1
        return Frame(shot.data, meta)

    def _set_exposure(self, seconds: float) -> None:  # noqa: B027 - optional hook
        """Send the exposure to the device (hook; the default only stores it)."""

    @abstractmethod
    def _expose(self) -> Exposure:
        """Expose and read the device: pixels, pattern id on display, light, extras."""


class LightSourceBase(ABC):
    """Checked :class:`~sassi_bench.rig.protocols.LightSource` skeleton."""

    def __init__(self, available: tuple[str, ...]) -> None:
        self._available = tuple(available)
        self._current = "off"

    @property
    def available(self) -> tuple[str, ...]:
        return self._available

    @property
    def current(self) -> str:
        return self._current

    def select(self, name: str) -> None:
        key = check_light(name, self._available)
        self._switch(key)
        self._current = key

    @abstractmethod
    def _switch(self, name: str) -> None:
        """Turn on light ``name`` (normalised) and everything else off."""


class TriggerBase(ABC):
    """Checked :class:`~sassi_bench.rig.protocols.Trigger` skeleton."""

    def __init__(self) -> None:
        self._armed = False
        self._divider = 1

    @property
    def armed(self) -> bool:
        return self._armed

    @property
    def divider(self) -> int:
        return self._divider

    def arm(self) -> None:
        self._arm(True)
        self._armed = True

    def disarm(self) -> None:
        self._arm(False)
        self._armed = False

    def set_divider(self, n: int) -> None:
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= 65535:
            raise ProcedureError(
                step_error(
                    "trigger divider",
                    f"{n!r} is not an integer in 1..65535",
                    "pass every n-th SLM pulse with an integer n >= 1",
                )
            )
        self._set_divider(int(n))
        self._divider = int(n)

    @abstractmethod
    def _arm(self, armed: bool) -> None:
        """Arm or disarm the device."""

    @abstractmethod
    def _set_divider(self, n: int) -> None:
        """Send the divider to the device."""

    @abstractmethod
    def counters(self) -> dict[str, int]:
        """Pulse counters."""
