"""A captured camera frame and its metadata."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["Frame", "FrameMeta"]


@dataclass(frozen=True)
class FrameMeta:
    """What was true when a frame was exposed.

    Parameters
    ----------
    camera
        Camera name (``"spectral"``, ``"guide"`` or an adapter's id).
    exposure_s
        Exposure time, seconds.
    timestamp
        POSIX time at the end of the exposure.
    pattern_id
        Id of the SLM pattern on display (``None`` if none was shown).
    light
        Name of the selected light (``"laser:532"``, ``"led"``, ``"off"`` ...).
    index
        Running frame number of this camera.
    extra
        Backend-specific additions (JSON-compatible).
    """

    camera: str
    exposure_s: float
    timestamp: float
    pattern_id: int | None
    light: str
    index: int
    extra: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-compatible form, for session event logs."""
        return asdict(self)


@dataclass(frozen=True)
class Frame:
    """Pixel data (read-only) with its :class:`FrameMeta`.

    Examples
    --------
    >>> import numpy as np
    >>> meta = FrameMeta("spectral", 0.01, 0.0, None, "off", 0)
    >>> Frame(np.zeros((2, 3), np.uint16), meta).shape
    (2, 3)
    """

    data: NDArray[Any]
    meta: FrameMeta

    def __post_init__(self) -> None:
        self.data.setflags(write=False)

    @property
    def shape(self) -> tuple[int, ...]:
        """Shape of :attr:`data`."""
        return tuple(self.data.shape)

    def as_float(self) -> NDArray[np.float64]:
        """A float64 copy of the data."""
        return self.data.astype(np.float64)
