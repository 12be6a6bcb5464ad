"""Why a decoded camera pixel is excluded: the reasons, their codes and counts.

The structured-light decoder tests every pixel in the order of :data:`REASONS` and
records the first test that fails. Besides simple thresholds it needs three checks
kept here: saturation in any raw frame, the dark frame's noise floor, and pixels whose
coordinate disagrees with their neighbours' (:func:`local_outliers`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from sassi_bench.calibrate import _frame_kernels as _kernels

__all__ = [
    "REASONS",
    "first_reason",
    "local_outliers",
    "noise_floor",
    "reason_counts",
    "saturated",
    "screen_outliers",
]

# Why a pixel is excluded, in the order the checks apply: a pixel is counted under the
# first reason that holds (code = index; 0 = valid).
REASONS = (
    "valid",
    "dark",
    "saturated",
    "low_modulation",
    "ambiguous_gray",
    "disagreement",
    "edge",
    "outlier",
)
_MAD_TO_SIGMA = 1.4826
# The outlier test compares each coordinate with the median of its valid neighbours in a
# window of this many camera pixels a side (needing at least _OUTLIER_MIN_NEIGHBOURS).
_OUTLIER_WINDOW = 5
_OUTLIER_MIN_NEIGHBOURS = 6


def saturated(stacks: Sequence[NDArray], level: float | None) -> NDArray[np.bool_]:
    """Pixels that reach ``level`` in any raw frame of any (N, H, W) stack.

    Parameters
    ----------
    stacks
        Raw frame stacks (before dark subtraction), all of one camera.
    level
        The raw value at which the camera saturates; ``None`` flags no pixel.

    Examples
    --------
    >>> frames = np.array([[[10, 65535]], [[20, 30]]], np.uint16)
    >>> saturated([frames], 65535).tolist(), saturated([frames], None).tolist()
    ([[False, True]], [[False, False]])
    """
    hit = np.zeros(stacks[0].shape[1:], dtype=bool)
    if level is None:
        return hit
    for stack in stacks:
        for frame in stack:
            hit |= frame >= level
    return hit


def noise_floor(dark: NDArray[np.float32]) -> float:
    """Ten times the dark frame's robust noise (MAD); 0 for a scalar black level.

    Examples
    --------
    >>> round(noise_floor(np.array([[100.0, 102.0, 98.0, 100.0]], np.float32)), 3)
    14.826
    >>> noise_floor(np.float32(100.0))
    0.0
    """
    if dark.ndim == 0:
        return 0.0
    mad = float(np.median(np.abs(dark - np.median(dark))))
    return 10.0 * _MAD_TO_SIGMA * mad


def first_reason(flags: Sequence[NDArray[np.bool_]]) -> NDArray[np.uint8]:
    """The first true flag of every pixel as a 1-based code, 0 where none holds.

    With ``flags`` in the order of :data:`REASONS` (from ``"dark"``), the code indexes it.

    Examples
    --------
    >>> first_reason([np.array([True, False, False]), np.array([True, True, False])]).tolist()
    [1, 2, 0]
    """
    reason = np.zeros(flags[0].shape, dtype=np.uint8)
    for code in range(len(flags), 0, -1):
        reason[flags[code - 1]] = code
    return reason


def reason_counts(reason: NDArray[np.uint8]) -> dict[str, int]:
    """Pixels in all (``"pixels"``), then per name of :data:`REASONS`.

    Examples
    --------
    >>> counts = reason_counts(np.array([[0, 0, 1, 7]], np.uint8))
    >>> counts["pixels"], counts["valid"], counts["dark"], counts["outlier"]
    (4, 2, 1, 1)
    """
    tally = np.bincount(reason.ravel(), minlength=len(REASONS))
    return {"pixels": int(reason.size), **{n: int(c) for n, c in zip(REASONS, tally, strict=True)}}


def local_outliers(
    coord: NDArray[np.float64], valid: NDArray[np.bool_], max_jump: float
) -> NDArray[np.bool_]:
    """Valid pixels whose coordinate is more than ``max_jump`` from their neighbours' median.

    The SLM -> camera map is smooth, so a pixel that disagrees with the valid pixels
    around it decoded a wrong Gray word or a corrupted phase (a hot pixel, stray light
    with spurious fringes). The coordinate changes by about one SLM pixel per camera
    pixel, so a plane fitted to all valid pixels is taken off first and the median is
    that of the residual (smooth to hundredths of a pixel over the window of 5 x 5
    camera pixels). Pixels with fewer than 6 valid neighbours to judge by are kept.

    Parameters
    ----------
    coord
        Decoded SLM coordinate (H, W).
    valid
        Pixels that passed the other checks (H, W); only these are judged and judge.
    max_jump
        Largest accepted distance from the neighbours' median, SLM px.

    Examples
    --------
    >>> coord = np.add.outer(np.zeros(7), np.arange(7.0))
    >>> coord[3, 3] += 2.0  # a wrong Gray word
    >>> np.argwhere(local_outliers(coord, np.ones((7, 7), bool), 0.5)).tolist()
    [[3, 3]]
    """
    reason = np.where(valid, 0, 1).astype(np.uint8)
    screen_outliers(np.asarray(coord, dtype=np.float64), reason, max_jump)
    return reason == REASONS.index("outlier")


def screen_outliers(coord: NDArray[np.float64], reason: NDArray[np.uint8], max_jump: float) -> int:
    """:func:`local_outliers` in place: the pixels of ``reason`` 0 that it finds get the
    ``outlier`` code; returns how many.

    The plane is fitted by its normal equations (sums over the pixels in float64) and
    each window is judged by a compiled loop that sorts only windows whose median could
    lie beyond ``max_jump`` (:func:`~sassi_bench.calibrate._frame_kernels.window_outliers`).

    Examples
    --------
    >>> coord = np.add.outer(np.zeros(7), np.arange(7.0))
    >>> coord[3, 3] += 2.0
    >>> reason = np.zeros((7, 7), np.uint8)
    >>> screen_outliers(coord, reason, 0.5), int(reason[3, 3])
    (1, 7)
    """
    matrix, rhs, count = _kernels.plane_sums(coord, reason)
    if count < 3:
        return 0
    plane = np.linalg.lstsq(matrix, rhs, rcond=None)[0]
    half = _OUTLIER_WINDOW // 2
    padded = np.empty((coord.shape[0] + 2 * half, coord.shape[1] + 2 * half), dtype=np.float32)
    _kernels.plane_residual(coord, reason, plane, padded, half)
    return int(
        _kernels.window_outliers(
            padded, reason, _OUTLIER_WINDOW, float(max_jump), _OUTLIER_MIN_NEIGHBOURS
        )
    )
