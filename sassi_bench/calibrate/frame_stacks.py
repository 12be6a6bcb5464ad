"""Camera frames as the sweep decoders take them: (N, H, W) stacks, a dark level, and
the arguments of their compiled loops.

The decoders accept raw uint16 or float frames, one at a time or stacked, and subtract
the dark frame themselves, pixel by pixel as they read each frame, so a sweep is never
held as floats.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["dark_argument", "dark_level", "frame_stack", "saturation_argument", "subtract_dark"]


def frame_stack(frames: ArrayLike, step: str, name: str, minimum: int = 1) -> NDArray:
    """``frames`` as an (N, H, W) array, dtype kept, with at least ``minimum`` frames.

    Parameters
    ----------
    frames
        The stacked frames.
    step, name
        The decoding step and the argument's name, for the error message.
    minimum
        The fewest frames the step needs.

    Raises
    ------
    ProcedureError
        For a stack that is not 3-D or has too few frames.

    Examples
    --------
    >>> frame_stack(np.zeros((3, 2, 4), np.uint16), "phase decoding", "phase").shape
    (3, 2, 4)
    >>> frame_stack(np.zeros((2, 4)), "phase decoding", "phase")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: phase decoding: phase has shape (2, 4), expected (N, H, W)...
    """
    arr = np.asarray(frames)
    fix = f"pass at least {minimum} frame(s) stacked as (N, H, W)"
    check_shape(arr, ("N", "H", "W"), step=step, name=name, fix=fix)
    if arr.shape[0] < minimum:
        raise ProcedureError(step_error(step, f"{name} has shape {arr.shape}", fix))
    return arr


def dark_level(dark: ArrayLike | None, shape: tuple[int, ...], step: str) -> NDArray[np.float32]:
    """The dark frame as float32 (H, W), or a float32 scalar (0 for ``None``).

    Examples
    --------
    >>> float(dark_level(None, (2, 3), "Gray decoding")), dark_level(7, (2, 3), "x").dtype
    (0.0, dtype('float32'))
    """
    if dark is None:
        return np.float32(0.0)
    arr = np.asarray(dark, dtype=np.float32)
    if arr.ndim != 0:
        check_shape(
            arr,
            tuple(shape),
            step=step,
            name="dark",
            expected_for="the frames",
            fix="pass a dark frame of the frames' shape, or a scalar dark level",
        )
    return arr


def subtract_dark(raw: ArrayLike, dark: NDArray[np.float32]) -> NDArray[np.float32]:
    """One raw frame as float32, minus the dark level.

    Examples
    --------
    >>> subtract_dark(np.array([[110, 90]], np.uint16), np.float32(100.0)).tolist()
    [[10.0, -10.0]]
    """
    return np.asarray(raw, dtype=np.float32) - dark


def dark_argument(dark: NDArray[np.float32]) -> tuple[NDArray[np.float32], bool]:
    """A :func:`dark_level` as the compiled decoders take it: a 2-D float32 array and
    whether it is a map (else its ``[0, 0]`` is every pixel's level).

    Examples
    --------
    >>> array, is_map = dark_argument(np.float32(100.0))
    >>> array.shape, is_map
    ((1, 1), False)
    """
    arr = np.asarray(dark, dtype=np.float32)
    if arr.ndim == 0:
        return arr.reshape(1, 1), False
    return np.ascontiguousarray(arr), True


def saturation_argument(level: float | None) -> float:
    """A saturation level as the compiled decoders take it: NaN (no test) for None.

    Examples
    --------
    >>> saturation_argument(None) != saturation_argument(None), saturation_argument(65535)
    (True, 65535.0)
    """
    return float("nan") if level is None else float(level)
