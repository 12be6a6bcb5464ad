"""How much of a frame is clipped, at full scale or at zero, in words with advice.

A saturated pixel has lost its value: its spectrum, its decoded SLM position or its
registration feature is wrong, silently. So wherever frames are shown, the fraction of
pixels at the sensor's full scale (and at zero, where a dark offset clips) is stated,
with what to change when it is more than a trace.

Examples
--------
>>> import numpy as np
>>> frame = np.zeros((10, 10), np.uint16); frame[:5] = 4095
>>> print(clipping(frame, bit_depth=12, name="all-open").describe())  # doctest: +ELLIPSIS
all-open: 50.0 % of pixels at full scale (4095 ADU), 50.0 % at zero. Saturated: ...
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["Clipping", "clip_level", "clipping", "clipping_of_views"]

#: Above this fraction of saturated pixels a frame gets advice (a few hot or specular
#: pixels are a trace; more is an exposure to change).
SATURATED_TOLERANCE = 1e-3
#: Above this fraction of pixels at zero the dark level clips (a camera's black level set
#: to zero, or a dark frame subtracted on board).
ZERO_TOLERANCE = 0.01
#: A sensor whose pixels fill before its ADC does clips below full scale (a datasheet's
#: full well is a typical value, a few per cent either way): a value above this fraction
#: of full scale that many pixels share is where the frames clip.
CLIP_SEARCH_FRACTION = 0.8
#: How many pixels must share that value: a bright peak that is not clipped reaches its
#: largest value in one pixel, or by chance in two or three.
CLIP_PILE_UP_PIXELS = 4


@dataclass(frozen=True)
class Clipping:
    """Clipped pixels of one frame.

    Attributes
    ----------
    name
        The frame, as a person knows it (``guide``, ``spectral all-open``).
    full_scale
        The sensor's largest value (ADU).
    saturated
        Fraction of pixels at full scale (a colour pixel counts when any channel is).
    zero
        Fraction of pixels at zero.
    brightest
        The frame's largest value, as a fraction of full scale.
    """

    name: str
    full_scale: int
    saturated: float
    zero: float
    brightest: float

    @property
    def ok(self) -> bool:
        """Whether the frame is clipped by no more than a trace."""
        return self.saturated <= SATURATED_TOLERANCE and self.zero <= ZERO_TOLERANCE

    def advice(self) -> str:
        """What to change, or an empty string when nothing needs to.

        Examples
        --------
        >>> Clipping("guide", 255, 0.0, 0.0, 0.8).advice()
        ''
        """
        notes = []
        if self.saturated > SATURATED_TOLERANCE:
            notes.append(
                "Saturated: those pixels' values (and any spectrum, decoded position or "
                "registration feature drawn from them) are wrong. Shorten the exposure "
                "(camera.set_exposure), dim the light or add an ND filter until fewer than "
                f"{SATURATED_TOLERANCE:.1%} of pixels reach full scale; the captures of the "
                "procedures set their own exposure (auto exposure), so this is about what "
                "you see here."
            )
        if self.zero > ZERO_TOLERANCE:
            notes.append(
                "Clipped at zero: the dark level is cut off, which biases every dark "
                "pixel; raise the camera's black level (offset) or lengthen the exposure."
            )
        return " ".join(notes)

    def describe(self) -> str:
        """One line with the fractions, then the advice when there is any.

        Examples
        --------
        >>> print(Clipping("guide", 255, 0.031, 0.0, 1.0).describe())  # doctest: +ELLIPSIS
        guide: 3.1 % of pixels at full scale (255 ADU), 0.0 % at zero. Saturated: ...
        """
        line = (
            f"{self.name}: {100 * self.saturated:.1f} % of pixels at full scale "
            f"({self.full_scale} ADU), {100 * self.zero:.1f} % at zero"
        )
        advice = self.advice()
        if not advice:
            return f"{line}; brightest {100 * self.brightest:.0f} % of full scale: fine"
        return f"{line}. {advice}"


def clip_level(frames: ArrayLike, full_scale: int) -> int:
    """The value at which ``frames`` clip: the sensor's full scale, or the largest value
    when at least :data:`CLIP_PILE_UP_PIXELS` pixels hold exactly it above
    :data:`CLIP_SEARCH_FRACTION` of full scale (the pixels' well filled first).

    Parameters
    ----------
    frames
        Raw frames, any shape.
    full_scale
        The sensor's largest value (ADU).

    Returns
    -------
    int
        Pixels at or above it are clipped.

    Examples
    --------
    >>> import numpy as np
    >>> peak = np.array([100, 900, 64713, 64713, 64713, 64713, 900], np.uint16)
    >>> clip_level(peak, 65535), clip_level(peak[:4], 65535)
    (64713, 65535)
    """
    data = np.asarray(frames)
    if data.size == 0:
        return int(full_scale)
    top = int(data.max())
    if top >= full_scale or top < CLIP_SEARCH_FRACTION * full_scale:
        return int(full_scale)
    return top if int(np.count_nonzero(data == top)) >= CLIP_PILE_UP_PIXELS else int(full_scale)


def clipping(frame: ArrayLike, *, bit_depth: int, name: str = "frame") -> Clipping:
    """Measure the clipped pixels of a frame.

    Parameters
    ----------
    frame
        (H, W) monochrome or (H, W, C) colour pixel values.
    bit_depth
        The sensor's bits per value (full scale ``2**bit_depth - 1``).
    name
        The frame's name in the description.

    Returns
    -------
    Clipping

    Examples
    --------
    >>> import numpy as np
    >>> clipping(np.array([[0, 255], [128, 255]], np.uint8), bit_depth=8).saturated
    0.5
    """
    data = np.asarray(frame)
    if data.ndim not in (2, 3):
        raise ValueError(f"{name}: a frame is (H, W) or (H, W, C), not {data.shape}")
    full_scale = 2 ** int(bit_depth) - 1
    at_top = data >= full_scale
    at_zero = data <= 0
    if data.ndim == 3:
        at_top = at_top.any(axis=-1)
        at_zero = at_zero.all(axis=-1)
    return Clipping(
        name=name,
        full_scale=full_scale,
        saturated=float(at_top.mean()),
        zero=float(at_zero.mean()),
        brightest=float(data.max()) / full_scale if data.size else 0.0,
    )


def clipping_of_views(views: Mapping[str, Any], rig: Any) -> list[Clipping]:
    """:func:`clipping` of each frame of ``views``, against its camera's bit depth.

    ``views`` maps names to :class:`~sassi_bench.rig.Frame` objects (as
    :func:`sassi_bench.acquire.views.capture_views` returns: each frame's ``meta.camera``
    names its camera) or to plain arrays (a stored frame: the guide camera's when its name
    starts with ``guide``, else the spectral camera's).

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        for c in clipping_of_views(capture_views(rig), rig):
            print(c.describe())
    """
    cameras = {"guide": rig.guide_camera, "spectral": rig.spectral_camera}
    found = []
    for name, frame in views.items():
        camera = cameras.get(getattr(getattr(frame, "meta", None), "camera", None))
        if camera is None:
            camera = cameras["guide" if name.lower().startswith("guide") else "spectral"]
        data = getattr(frame, "data", frame)
        found.append(clipping(data, bit_depth=camera.bit_depth, name=name.replace("_", " ")))
    return found
