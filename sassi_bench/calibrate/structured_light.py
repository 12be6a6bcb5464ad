"""Decode structured-light sweeps into camera pixel -> SLM pixel correspondences.

Under a laser line the SLM -> camera map is a smooth warp. Each SLM axis ("x": columns
u, "y": rows v) is coded twice:

* a **Gray code** in blocks of ``block`` px, every bit followed by its inverse, gives
  the block each camera pixel sees (robust, coarse: +-block/2);
* **phase shifting**: ``S`` frames of transmission
  ``t_s(p) = 0.5 + 0.5 cos(2 pi (p - shift_s) / period)`` give the position within a
  period to a small fraction of a pixel. The Gray estimate picks the period
  (:func:`unwrap`).

Coordinates follow the workbench convention: pixel centres at integers, arrays indexed
``[row, col]``; SLM pixel ``p`` spans ``p - 0.5 .. p + 0.5`` and Gray block ``k`` is
centred on ``block * k + (block - 1) / 2``.

Every function is vectorised over pixels (loops run over bits and phase steps only)
and takes frames as uint16 or float, subtracting the dark frame itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike, NDArray

from sassi_bench.acquire.patterns import gray_bit_count
from sassi_bench.errors import ProcedureError, step_error

__all__ = [
    "REASONS",
    "AxisDecode",
    "Correspondences",
    "blur_from_modulation",
    "decode_axis",
    "decode_correspondences",
    "decode_gray",
    "decode_phase",
    "unwrap",
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
# Joint fit of per-frame gains (see _frame_gains): pixels sampled and iterations at most.
_GAIN_PIXELS = 50_000
_GAIN_ITERATIONS = 200
# Default border margin, in blur sigmas (plus half a pixel): a Gaussian spot truncated
# 2.5 sigma from its centre is pulled inwards by under 0.02 sigma.
_EDGE_SIGMAS = 2.5
# The outlier test compares each coordinate with the median of its valid neighbours in a
# window of this many camera pixels a side (needing at least _OUTLIER_MIN_NEIGHBOURS).
_OUTLIER_WINDOW = 5
_OUTLIER_MIN_NEIGHBOURS = 6


# -- input handling -------------------------------------------------------------------
def _stack(frames: ArrayLike, step: str, name: str, minimum: int = 1) -> NDArray:
    """``frames`` as an (N, H, W) array (dtype kept; converted frame by frame later)."""
    arr = np.asarray(frames)
    if arr.ndim != 3 or arr.shape[0] < minimum:
        raise ProcedureError(
            step_error(
                step,
                f"{name} has shape {arr.shape}",
                f"pass at least {minimum} frame(s) stacked as (N, H, W)",
            )
        )
    return arr


def _check_frame_shape(shape: tuple[int, ...], expected: tuple[int, ...], step: str, name: str):
    if tuple(shape) != tuple(expected):
        raise ProcedureError(
            step_error(
                step,
                f"{name} frames are {tuple(shape)}, the others are {tuple(expected)}",
                "pass frames of one camera, all of the same shape",
            )
        )


def _dark(dark: ArrayLike | None, shape: tuple[int, int], step: str) -> NDArray[np.float32]:
    """The dark frame as float32 (H, W) or a float32 scalar."""
    if dark is None:
        return np.float32(0.0)
    arr = np.asarray(dark, dtype=np.float32)
    if arr.ndim != 0:
        _check_frame_shape(arr.shape, shape, step, "dark")
    return arr


def _frame(raw: ArrayLike, dark: NDArray[np.float32]) -> NDArray[np.float32]:
    return np.asarray(raw, dtype=np.float32) - dark


# -- Gray code ------------------------------------------------------------------------
def _gray_core(
    positive: NDArray, negative: NDArray, dark: NDArray[np.float32]
) -> tuple[NDArray[np.int64], NDArray[np.float32], NDArray[np.float32]]:
    """Block index and the smallest and second-smallest bit contrast of every pixel."""
    shape = positive.shape[1:]
    index = np.zeros(shape, dtype=np.int64)
    binary = np.zeros(shape, dtype=bool)
    smallest = np.full(shape, np.inf, dtype=np.float32)
    second = np.full(shape, np.inf, dtype=np.float32)
    for pos_raw, neg_raw in zip(positive, negative, strict=True):
        pos, neg = _frame(pos_raw, dark), _frame(neg_raw, dark)
        total = pos + neg
        contrast = np.abs(pos - neg) / np.where(total > 0, total, np.float32(np.inf))
        # Binary bit b is the XOR of Gray bits 0..b (most significant first).
        binary ^= pos > neg
        index = (index << 1) | binary
        second = np.minimum(second, np.maximum(smallest, contrast))
        smallest = np.minimum(smallest, contrast)
    return index, smallest, second


def decode_gray(
    positive: ArrayLike,
    negative: ArrayLike,
    block: int,
    min_margin: float = 0.2,
    *,
    dark: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float32], NDArray[np.bool_]]:
    """Decode Gray-code frames (every bit with its inverse) into block-centre coordinates.

    Parameters
    ----------
    positive, negative
        Frames (bits, H, W) of the Gray bits (bit 0 = most significant) and of their
        inverse patterns.
    block
        SLM pixels per code word.
    min_margin
        Smallest acceptable bit contrast ``|pos - neg| / (pos + neg)``.
    dark
        Dark frame (H, W) or scalar, subtracted before the contrast is formed.

    Returns
    -------
    coord : ndarray
        ``block * index + (block - 1) / 2`` (H, W): the centre of the decoded block.
    margin : ndarray
        The smallest bit contrast of each pixel (0 = undecidable, 1 = perfect).
    valid : ndarray
        ``margin >= min_margin``. Pixels on a block boundary have one undecidable bit
        and are flagged here, though either neighbouring block is a fine coarse estimate
        for phase unwrapping (:func:`decode_axis` allows one such bit).

    Examples
    --------
    >>> from sassi_bench.acquire.patterns import gray_bit_count, gray_pattern
    >>> bits = range(gray_bit_count(32, 4))
    >>> pos = np.stack([gray_pattern((1, 32), "x", b, 4) for b in bits])
    >>> neg = np.stack([gray_pattern((1, 32), "x", b, 4, inverse=True) for b in bits])
    >>> coord, margin, valid = decode_gray(pos, neg, block=4)
    >>> coord[0, :6].tolist(), bool(valid.all())
    ([1.5, 1.5, 1.5, 1.5, 5.5, 5.5], True)
    """
    step = "Gray decoding"
    pos = _stack(positive, step, "positive")
    neg = _stack(negative, step, "negative")
    if neg.shape != pos.shape:
        raise ProcedureError(
            step_error(
                step,
                f"positive frames {pos.shape} and negative frames {neg.shape} differ",
                "pass one inverse frame per Gray bit, in the same order",
            )
        )
    _check_block(block, step)
    index, margin, _ = _gray_core(pos, neg, _dark(dark, pos.shape[1:], step))
    coord = block * index + (block - 1) / 2.0
    return coord, margin, margin >= min_margin


def _check_block(block: int, step: str) -> None:
    if isinstance(block, bool) or not isinstance(block, (int, np.integer)) or block < 1:
        raise ProcedureError(
            step_error(step, f"block {block!r} is not a positive integer", "use e.g. block=8")
        )


# -- phase shifting -------------------------------------------------------------------
def _phase_solver(shifts: NDArray[np.float64], period: float, step: str) -> NDArray[np.float64]:
    """Least-squares solver (3, S) for offset and quadrature amplitudes of the frames."""
    delta = 2.0 * np.pi * shifts / period
    design = np.stack([np.ones_like(delta), np.cos(delta), np.sin(delta)], axis=1)
    if np.linalg.matrix_rank(design) < 3:
        raise ProcedureError(
            step_error(
                step,
                f"phase shifts {shifts.tolist()} px do not span a period of {period} px",
                "use at least 3 distinct shifts, e.g. s * period // steps",
            )
        )
    return np.linalg.pinv(design)


def decode_phase(
    frames: ArrayLike,
    period: float,
    *,
    dark: ArrayLike | None = None,
    shifts: Sequence[float] | None = None,
    normalise: bool = True,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Decode phase-shifted sinusoid frames into a position within the period.

    Frame ``s`` is modelled as ``g_s (A + B cos(theta - 2 pi shift_s / period))``; with
    equal steps and equal frame gains ``g_s`` this is the classic
    ``atan2(sum I_s sin d_s, sum I_s cos d_s)``, and for any other shifts the same
    least-squares fit. The gains (one per frame, for a light source whose power drifts)
    are estimated robustly from a first fit and divided out.

    Parameters
    ----------
    frames
        Frames (S, H, W), S >= 3, of transmission
        ``0.5 + 0.5 cos(2 pi (p - shift_s) / period)`` along the axis.
    period
        Fringe period, SLM px.
    dark
        Dark frame (H, W) or scalar (affects ``offset`` only).
    shifts
        Pattern shifts (px) of the frames; default ``s * period // S``, as a
        ``periodic`` pattern descriptor realises them.
    normalise
        Estimate every frame's overall light level from the frames themselves and
        divide it out before the final fit (with more than 3 frames): a laser whose
        power jitters by 1 % from frame to frame otherwise shifts the decoded phase.

    Returns
    -------
    phase_coord : ndarray
        ``period * theta / (2 pi)`` wrapped into ``[0, period)`` (H, W).
    modulation : ndarray
        Fringe amplitude ``B`` (H, W), in frame units.
    offset : ndarray
        Mean level ``A`` (H, W), dark-subtracted.

    Examples
    --------
    >>> p = np.arange(32.0)
    >>> frames = np.stack([0.5 + 0.5 * np.cos(2 * np.pi * (p - 2 * s) / 16) for s in range(8)])
    >>> coord, modulation, offset = decode_phase(frames[:, None, :], period=16)
    >>> np.round(coord[0, [0, 1, 15, 17]], 6).tolist(), round(float(modulation[0, 0]), 6)
    ([0.0, 1.0, 15.0, 1.0], 0.5)
    """
    step = "phase decoding"
    stack = _stack(frames, step, "phase frames", minimum=3)
    if not np.isfinite(period) or period <= 0:
        raise ProcedureError(step_error(step, f"period {period!r} is not positive", "use e.g. 16"))
    count = stack.shape[0]
    if shifts is None:
        shifts = np.arange(count) * period // count
    shifts = np.asarray(shifts, dtype=np.float64)
    if shifts.shape != (count,):
        raise ProcedureError(
            step_error(step, f"{shifts.size} shifts for {count} frames", "pass one per frame")
        )
    solver = _phase_solver(shifts, float(period), step)
    dark_arr = _dark(dark, stack.shape[1:], step)
    coef = _phase_coefficients(stack, dark_arr, solver)
    if normalise and count > 3:
        design = np.linalg.pinv(solver)
        gains = _frame_gains(stack, dark_arr, coef, solver, design)
        coef = _phase_coefficients(stack, dark_arr, solver / gains[None, :])
    theta = np.arctan2(coef[2], coef[1])
    coord = np.mod(theta * (period / (2.0 * np.pi)), period)
    coord[coord >= period] = 0.0  # mod of a tiny negative number can round up to period
    return coord, np.hypot(coef[1], coef[2]), coef[0]


def _phase_coefficients(
    stack: NDArray, dark: NDArray[np.float32], solver: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Offset and quadrature amplitudes (3, H, W): ``solver`` applied to the frames."""
    coef = np.zeros((3, *stack.shape[1:]), dtype=np.float64)
    for s, raw in enumerate(stack):
        frame = _frame(raw, dark)
        for k in range(3):
            coef[k] += solver[k, s] * frame
    return coef


def _frame_gains(
    stack: NDArray,
    dark: NDArray[np.float32],
    coef: NDArray[np.float64],
    solver: NDArray[np.float64],
    design: NDArray[np.float64],
) -> NDArray[np.float64]:
    """Each phase frame's light level relative to the others (mean 1), (S,).

    A source whose power drifts from frame to frame (a laser's power jitter) scales
    whole frames; the sinusoid fit reads the drift as a phase error of up to
    ``jitter * A / B`` radians. One pixel cannot tell a gain from a phase (the part of
    the drift that looks like a sinusoid is absorbed into its fit), but pixels at
    different phases can: the gains and every pixel's sinusoid are fitted jointly by
    alternating least squares (frames divided by the gains -> per-pixel fit -> gains
    from all pixels) on a regular subsample of the well-modulated pixels.
    """
    usable = (coef[0] > 0) & (np.hypot(coef[1], coef[2]) > 0.2 * coef[0])
    rows, cols = np.nonzero(usable)
    count = stack.shape[0]
    if rows.size < 100:
        return np.ones(count)
    stride = max(1, rows.size // _GAIN_PIXELS)
    rows, cols = rows[::stride], cols[::stride]
    dark_at = dark if dark.ndim == 0 else dark[rows, cols]
    frames = np.stack([np.asarray(raw[rows, cols], dtype=np.float64) - dark_at for raw in stack])
    gains = np.ones(count)
    for _ in range(_GAIN_ITERATIONS):
        model = design @ (solver @ (frames / gains[:, None]))
        new = np.sum(frames * model, axis=1) / np.sum(model * model, axis=1)
        new /= new.mean()
        converged = np.max(np.abs(new - gains)) < 1e-6
        gains = new
        if converged:
            break
    return gains


def unwrap(phase_coord: ArrayLike, coarse_coord: ArrayLike, period: float) -> NDArray[np.float64]:
    """Add the whole number of periods that brings ``phase_coord`` nearest ``coarse_coord``.

    Parameters
    ----------
    phase_coord
        Position within the period, ``[0, period)``.
    coarse_coord
        A coarse absolute estimate (e.g. the Gray-code block centre), good to better
        than ``period / 2``.
    period
        Fringe period, px.

    Examples
    --------
    >>> unwrap([15.9, 0.1, 8.0], [19.5, 27.5, 40.0], 16).tolist()
    [15.9, 32.1, 40.0]
    """
    phase = np.asarray(phase_coord, dtype=np.float64)
    coarse = np.asarray(coarse_coord, dtype=np.float64)
    return phase + period * np.rint((coarse - phase) / period)


# -- one axis -------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class AxisDecode:
    """The decoded SLM coordinate along one axis, for every camera pixel.

    Attributes
    ----------
    coord
        SLM coordinate (H, W), NaN where not valid.
    valid
        Pixels that passed every check (H, W).
    modulation
        Fringe modulation depth ``B / A`` (H, W): 1 for full-contrast sinusoids, lower
        where blur or stray light washes the fringes out.
    counts
        Pixels per outcome: ``"pixels"`` (all), then every name of :data:`REASONS`;
        a pixel is counted once, under the first reason that excludes it.
    reason
        Code of that first reason (H, W), an index into :data:`REASONS` (0 = valid).
    coarse
        The Gray-code block centre (H, W), for diagnostics.
    blur_sigma
        Line-spread sigma along the axis (SLM px), estimated from the median
        modulation depth of the decodable pixels (see :func:`blur_from_modulation`).
    edge_margin
        The border margin (SLM px) the ``edge`` test used.
    """

    coord: NDArray[np.float64]
    valid: NDArray[np.bool_]
    modulation: NDArray[np.float64]
    counts: dict[str, int]
    reason: NDArray[np.uint8]
    coarse: NDArray[np.float64]
    blur_sigma: float
    edge_margin: float


def blur_from_modulation(depth: ArrayLike, period: float) -> NDArray[np.float64]:
    """Gaussian blur sigma (px) that reduces a fringe of ``period`` px to modulation ``depth``.

    A Gaussian line spread of sigma ``s`` multiplies a sinusoid of period ``P`` by
    ``exp(-2 pi^2 s^2 / P^2)``. A camera pixel that integrates over whole SLM pixels
    also sees their box (variance 1/12), so a perfectly sharp relay reads about 0.29 px.

    Examples
    --------
    >>> s = 1.5
    >>> round(float(blur_from_modulation(np.exp(-2 * np.pi**2 * s**2 / 16**2), 16)), 6)
    1.5
    """
    d = np.clip(np.asarray(depth, dtype=np.float64), 1e-12, 1.0)
    return period / (np.pi * np.sqrt(2.0)) * np.sqrt(-np.log(d))


def _median_blur(depth: NDArray[np.float64], usable: NDArray[np.bool_], period: float) -> float:
    """Blur sigma of the median modulation depth over ``usable`` pixels (0 if none)."""
    if not np.any(usable):
        return 0.0
    return float(blur_from_modulation(np.median(depth[usable]), period))


def _saturated(stacks: Sequence[NDArray], level: float | None) -> NDArray[np.bool_]:
    shape = stacks[0].shape[1:]
    hit = np.zeros(shape, dtype=bool)
    if level is None:
        return hit
    for stack in stacks:
        for frame in stack:
            hit |= frame >= level
    return hit


def _default_min_signal(dark: NDArray[np.float32]) -> float:
    """Ten times the dark frame's robust noise (0 when only a scalar black level is known)."""
    if dark.ndim == 0:
        return 0.0
    mad = float(np.median(np.abs(dark - np.median(dark))))
    return 10.0 * _MAD_TO_SIGMA * mad


def _reason_codes(flags: Sequence[NDArray[np.bool_]]) -> NDArray[np.uint8]:
    """First true flag per pixel, as 1-based codes (0 where none)."""
    reason = np.zeros(flags[0].shape, dtype=np.uint8)
    for code in range(len(flags), 0, -1):
        reason[flags[code - 1]] = code
    return reason


def _counts(reason: NDArray[np.uint8]) -> dict[str, int]:
    tally = np.bincount(reason.ravel(), minlength=len(REASONS))
    return {"pixels": int(reason.size), **{n: int(c) for n, c in zip(REASONS, tally, strict=True)}}


def _local_outliers(
    coord: NDArray[np.float64], valid: NDArray[np.bool_], max_jump: float
) -> NDArray[np.bool_]:
    """Valid pixels whose coordinate is more than ``max_jump`` from their neighbours' median.

    The SLM -> camera map is smooth, so a pixel that disagrees with the valid pixels
    around it decoded a wrong Gray word or a corrupted phase (a hot pixel, stray light
    with spurious fringes). The coordinate changes by about one SLM pixel per camera
    pixel, so a plane fitted to all valid pixels is taken off first and the median is
    that of the residual (smooth to hundredths of a pixel over the window). Pixels with
    too few valid neighbours to judge are kept.
    """
    out = np.zeros(coord.shape, dtype=bool)
    rows, cols = np.nonzero(valid)
    if rows.size < 3:
        return out
    design = np.stack([cols, rows, np.ones_like(rows)], axis=1).astype(np.float64)
    plane = np.linalg.lstsq(design, coord[rows, cols], rcond=None)[0]
    residual = np.full(coord.shape, np.inf, dtype=np.float32)
    residual[rows, cols] = coord[rows, cols] - design @ plane
    half = _OUTLIER_WINDOW // 2
    padded = np.pad(residual, half, constant_values=np.inf)
    windows = sliding_window_view(padded, (_OUTLIER_WINDOW, _OUTLIER_WINDOW))[rows, cols]
    ordered = np.sort(windows.reshape(rows.size, -1), axis=1)  # invalid (inf) sort last
    count = np.sum(np.isfinite(ordered), axis=1)
    median = 0.5 * (
        np.take_along_axis(ordered, ((count - 1) // 2)[:, None], axis=1)[:, 0]
        + np.take_along_axis(ordered, (count // 2)[:, None], axis=1)[:, 0]
    )
    jump = np.abs(residual[rows, cols] - median)
    out[rows, cols] = (count - 1 >= _OUTLIER_MIN_NEIGHBOURS) & (jump > max_jump)
    return out


def _check_axis_inputs(
    pos: NDArray,
    neg: NDArray,
    fringes: NDArray,
    blank: NDArray,
    full: NDArray,
    length: int,
    block: int,
    period: float,
    tolerance: float,
) -> None:
    """Shapes, bit count and the Gray/phase geometry of :func:`decode_axis`'s inputs."""
    step = "structured-light decoding"
    shape = pos.shape[1:]
    _check_frame_shape(neg.shape, pos.shape, step, "gray_negative")
    _check_frame_shape(fringes.shape[1:], shape, step, "phase")
    _check_frame_shape(blank.shape, shape, step, "blank")
    _check_frame_shape(full.shape, shape, step, "full")
    _check_block(block, step)
    if isinstance(length, bool) or not isinstance(length, (int, np.integer)) or length < 1:
        raise ProcedureError(
            step_error(
                step,
                f"length {length!r} is not a positive integer",
                "pass the SLM's width (axis x) or height (axis y) in pixels",
            )
        )
    bits = gray_bit_count(length, block)
    if pos.shape[0] != bits:
        raise ProcedureError(
            step_error(
                step,
                f"{pos.shape[0]} Gray bits given; {length} px in blocks of {block} need {bits}",
                "pass every bit of the sweep, and the same length and block as the plan",
            )
        )
    if not 0 <= tolerance < period / 2 or block / 2 > period / 2 - tolerance:
        raise ProcedureError(
            step_error(
                step,
                f"Gray blocks of {block} px cannot pick a period of {period} px with "
                f"tolerance {tolerance} px",
                "use block <= period - 2 * tolerance (e.g. block 8, period 16, tolerance 2)",
            )
        )


def decode_axis(
    gray_positive: ArrayLike,
    gray_negative: ArrayLike,
    phase: ArrayLike,
    *,
    blank: ArrayLike,
    full: ArrayLike,
    length: int,
    dark: ArrayLike | None = None,
    block: int = 8,
    period: int = 16,
    shifts: Sequence[float] | None = None,
    saturation_level: float | None = 65535,
    min_signal: float | None = None,
    edge_margin: float | None = None,
    min_modulation: float = 0.25,
    min_margin: float = 0.2,
    tolerance: float = 2.0,
    min_relative_signal: float = 0.05,
    max_jump: float = 0.5,
) -> AxisDecode:
    """Decode one SLM axis from its Gray-code and phase-shift frames, with a validity mask.

    A pixel is excluded (and counted) for the first of these that holds:

    ``dark``
        ``full - blank <= min_signal``, or at most ``min_relative_signal`` of the frame's
        bright level (its 99.5th percentile): too little light to decode. The relative
        floor keeps out pixels lit only by stray light, whose fringes are not the SLM's.
    ``saturated``
        Some raw frame reaches ``saturation_level``.
    ``low_modulation``
        Fringe modulation depth ``B / A`` below ``min_modulation``.
    ``ambiguous_gray``
        More than one Gray bit has contrast below ``min_margin`` (one is normal on a
        block boundary, where either neighbouring block is a good coarse estimate).
    ``disagreement``
        The unwrapped phase lies more than ``period / 2 - tolerance`` from the Gray
        block centre, so the period choice is unsafe.
    ``edge``
        The decoded coordinate lies within ``edge_margin`` px of the SLM's border
        (``-0.5`` or ``length - 0.5``): part of the pixel's blur spot falls off the
        SLM, which pulls the decoded position inwards (by ~0.4 px on the border
        itself at sigma 0.5 px). By default the margin is ``0.5 + 2.5 sigma``, with
        the blur sigma estimated from the fringes' modulation depth
        (:func:`blur_from_modulation`).
    ``outlier``
        The coordinate lies more than ``max_jump`` SLM px from the median of the
        valid pixels within 2 camera px: the map is smooth, so the pixel decoded a
        wrong Gray word or a corrupted phase.

    Parameters
    ----------
    gray_positive, gray_negative
        Gray-bit frames and their inverses (bits, H, W), bit 0 most significant.
    phase
        Phase-shift frames (S, H, W), S >= 3.
    blank, full
        Frames (H, W) with the SLM fully closed and fully open.
    length
        SLM pixels along this axis (its width for "x", its height for "y").
    dark
        Dark frame (light off) (H, W) or scalar black level.
    block, period
        Gray block and fringe period, SLM px.
    shifts
        Pattern shifts of the phase frames (px); default ``s * period // S``.
    saturation_level
        Raw value (before dark subtraction) at which the camera saturates; ``None``
        skips the check.
    min_signal
        Smallest usable ``full - blank``; default ten times the dark frame's robust
        noise (MAD), or 0 for a scalar ``dark``.
    edge_margin, min_modulation, min_margin, tolerance, min_relative_signal, max_jump
        Thresholds of the tests above (px, ratio, contrast, px, ratio, px);
        ``edge_margin=None`` derives the margin from the measured blur.

    Returns
    -------
    AxisDecode

    Examples
    --------
    >>> from sassi_bench.acquire.patterns import gray_bit_count, render_pattern
    >>> from sassi_bench.calibrate.grey_response import sinusoid_profile
    >>> def show(**d):  # a noiseless camera that sees the SLM pixel for pixel
    ...     return 10.0 + 1000.0 * render_pattern(d, (2, 64)) / 255.0
    >>> bits = range(gray_bit_count(64, 8))
    >>> pos = np.stack([show(kind="gray", axis="x", bit=b, block=8, inverse=False) for b in bits])
    >>> neg = np.stack([show(kind="gray", axis="x", bit=b, block=8, inverse=True) for b in bits])
    >>> profile = sinusoid_profile(16)
    >>> ph = np.stack([show(kind="periodic", axis="x", profile=profile, shift=2 * s)
    ...                for s in range(8)])
    >>> axis = decode_axis(pos, neg, ph, blank=show(kind="blank"), full=show(kind="full"),
    ...                    length=64, dark=10.0)
    >>> bool(np.nanmax(np.abs(axis.coord - np.arange(64))) < 0.02), axis.counts["valid"]
    (True, 124)
    """
    step = "structured-light decoding"
    pos = _stack(gray_positive, step, "gray_positive")
    neg = _stack(gray_negative, step, "gray_negative")
    fringes = _stack(phase, step, "phase", minimum=3)
    blank_raw, full_raw = np.asarray(blank), np.asarray(full)
    _check_axis_inputs(pos, neg, fringes, blank_raw, full_raw, length, block, period, tolerance)
    shape = pos.shape[1:]
    dark_arr = _dark(dark, shape, step)

    signal = _frame(full_raw, dark_arr) - _frame(blank_raw, dark_arr)
    floor = _default_min_signal(dark_arr) if min_signal is None else float(min_signal)
    bright = float(np.percentile(signal, 99.5)) if signal.size else 0.0
    floor = max(floor, min_relative_signal * bright)
    is_dark = ~(signal > floor)
    saturated = _saturated([full_raw[None], blank_raw[None], pos, neg, fringes], saturation_level)

    index, _, second_margin = _gray_core(pos, neg, dark_arr)
    coarse = block * index + (block - 1) / 2.0
    phase_coord, amplitude, offset = decode_phase(fringes, period, dark=dark_arr, shifts=shifts)
    with np.errstate(divide="ignore", invalid="ignore"):
        depth = np.where(offset > 0, amplitude / offset, 0.0)
    coord = unwrap(phase_coord, coarse, period)
    blur = _median_blur(depth, (depth >= min_modulation) & ~is_dark & ~saturated, period)
    margin = 0.5 + _EDGE_SIGMAS * blur if edge_margin is None else float(edge_margin)

    flags = [
        is_dark,
        saturated,
        ~(depth >= min_modulation),
        second_margin < min_margin,
        np.abs(coord - coarse) > period / 2 - tolerance,
        (coord < margin - 0.5) | (coord > length - 0.5 - margin),
    ]
    passed = _reason_codes(flags) == 0
    reason = _reason_codes([*flags, _local_outliers(coord, passed, max_jump)])
    valid = reason == 0
    return AxisDecode(
        coord=np.where(valid, coord, np.nan),
        valid=valid,
        modulation=depth,
        counts=_counts(reason),
        reason=reason,
        coarse=coarse,
        blur_sigma=blur,
        edge_margin=margin,
    )


# -- both axes ------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Correspondences:
    """Camera pixel <-> SLM pixel pairs from a structured-light sweep at one wavelength.

    Attributes
    ----------
    x, y
        Camera column and row of every valid pixel (N,), pixel centres at integers.
    u, v
        Their decoded SLM column and row (N,).
    u_map, v_map
        The decoded SLM coordinates over the whole frame (H, W), NaN where not valid.
    valid
        Pixels decoded on both axes (H, W).
    counts
        ``"pixels"``, then every name of :data:`REASONS`: each pixel counted once,
        under the first reason (in that order) that excludes it on either axis.
    reason
        That reason's code (H, W), an index into :data:`REASONS`.
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    u_map: NDArray[np.float64]
    v_map: NDArray[np.float64]
    valid: NDArray[np.bool_]
    counts: dict[str, int]
    reason: NDArray[np.uint8]

    def __len__(self) -> int:
        return int(self.x.size)


def decode_correspondences(x_axis: AxisDecode, y_axis: AxisDecode) -> Correspondences:
    """Combine the decoded x (SLM columns) and y (SLM rows) axes into correspondences.

    Parameters
    ----------
    x_axis, y_axis
        :func:`decode_axis` results of the same camera for the two axes.

    Returns
    -------
    Correspondences

    Raises
    ------
    ValueError
        If the axes' shapes differ or no pixel is valid on both.

    Examples
    --------
    >>> yy, xx = np.mgrid[0:2, 0:3].astype(float)
    >>> ok = np.ones((2, 3), bool)
    >>> def axis(c):
    ...     counts = {"pixels": 6, "valid": 6}
    ...     return AxisDecode(c, ok, ok * 1.0, counts, np.zeros((2, 3), np.uint8), c, 0.5, 1.0)
    >>> pairs = decode_correspondences(axis(xx + 0.5), axis(yy - 0.5))
    >>> len(pairs), pairs.u[:2].tolist(), float(pairs.v[-1])
    (6, [0.5, 1.5], 0.5)
    """
    step = "correspondences"
    if x_axis.coord.shape != y_axis.coord.shape:
        raise ProcedureError(
            step_error(
                step,
                f"x axis is {x_axis.coord.shape}, y axis is {y_axis.coord.shape}",
                "decode both axes from frames of the same camera",
            )
        )
    rx, ry = x_axis.reason, y_axis.reason
    reason = np.where((rx == 0) | ((ry != 0) & (ry < rx)), ry, rx).astype(np.uint8)
    valid = reason == 0
    counts = _counts(reason)
    if not np.any(valid):
        raise ProcedureError(
            step_error(
                step,
                f"no pixel was decoded on both axes (counts {counts})",
                "check the light, the exposure (dark or saturated frames) and the pattern order",
            )
        )
    rows, cols = np.nonzero(valid)
    u_map = np.where(valid, x_axis.coord, np.nan)
    v_map = np.where(valid, y_axis.coord, np.nan)
    return Correspondences(
        x=cols.astype(np.float64),
        y=rows.astype(np.float64),
        u=u_map[valid],
        v=v_map[valid],
        u_map=u_map,
        v_map=v_map,
        valid=valid,
        counts=counts,
        reason=reason,
    )
