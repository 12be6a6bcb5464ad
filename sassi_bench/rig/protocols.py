"""The device protocols every backend implements: Slm, Camera, LightSource, Trigger.

Procedures are written against these small typed protocols only, so they run
unchanged on the virtual bench and on a real one. Argument checking lives in the
shared base classes of :mod:`sassi_bench.rig.base`; a backend implements the
underscore hooks and inherits the checks, and the contract tests in
``tests/rig/test_contract.py`` hold every backend to the same behaviour.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.rig.frame import Frame

__all__ = ["Camera", "LightSource", "Slm", "Trigger"]


@runtime_checkable
class Slm(Protocol):
    """A spatial light modulator showing 8-bit or boolean patterns."""

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) in pixels."""
        ...

    @property
    def pattern_id(self) -> int | None:
        """Id of the pattern on display (increments with every :meth:`show`)."""
        ...

    def show(self, pattern: ArrayLike) -> int:
        """Display ``pattern`` (bool or uint8, shape :attr:`shape`); return its id."""
        ...

    def current_pattern(self) -> NDArray[np.uint8]:
        """A copy of the pattern on display, as uint8 (255 = fully open)."""
        ...


@runtime_checkable
class Camera(Protocol):
    """A camera returning :class:`Frame` objects."""

    name: str

    @property
    def shape(self) -> tuple[int, ...]:
        """Frame shape: (height, width) or (height, width, 3)."""
        ...

    @property
    def bit_depth(self) -> int:
        """ADC bits of the pixel values."""
        ...

    @property
    def exposure_range_s(self) -> tuple[float, float]:
        """Shortest and longest allowed exposure, seconds."""
        ...

    @property
    def exposure_s(self) -> float:
        """Current exposure, seconds."""
        ...

    def set_exposure(self, seconds: float) -> None:
        """Set the exposure; ``ValueError`` outside :attr:`exposure_range_s`."""
        ...

    def capture(self) -> Frame:
        """Expose and read one frame."""
        ...


@runtime_checkable
class LightSource(Protocol):
    """A set of selectable lights (lasers, LED, lamps) in front of the scene."""

    @property
    def available(self) -> tuple[str, ...]:
        """Names accepted by :meth:`select` (``"laser:532"``, ``"led"``, ``"off"`` ...)."""
        ...

    @property
    def current(self) -> str:
        """The selected light."""
        ...

    def select(self, name: str) -> None:
        """Switch to light ``name``; ``ValueError`` for an unknown one."""
        ...


@runtime_checkable
class Trigger(Protocol):
    """The exposure gate between the SLM's master pulse and the cameras."""

    @property
    def armed(self) -> bool:
        """Whether pulses are passed to the cameras."""
        ...

    @property
    def divider(self) -> int:
        """Every n-th SLM pulse is passed."""
        ...

    def arm(self) -> None:
        """Start passing pulses."""
        ...

    def disarm(self) -> None:
        """Stop passing pulses."""
        ...

    def set_divider(self, n: int) -> None:
        """Pass every ``n``-th pulse (n >= 1); ``ValueError`` otherwise."""
        ...

    def counters(self) -> dict[str, int]:
        """Pulse counters: ``{"received": ..., "passed": ...}``."""
        ...
