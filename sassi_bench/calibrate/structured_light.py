"""Decode structured-light sweeps into camera pixel -> SLM pixel correspondences.

Under a laser line the SLM -> camera map is a smooth warp. Each SLM axis ("x": columns
u, "y": rows v) is coded twice: a Gray code in blocks of ``block`` px gives the block
each camera pixel sees (:mod:`~sassi_bench.calibrate.gray_decode`, robust and coarse),
phase-shifted fringes give the position within a period to a small fraction of a pixel
(:mod:`~sassi_bench.calibrate.phase_decode`), and the Gray estimate picks the period.
:func:`decode_axis` combines them for one axis and excludes the pixels it cannot trust
(:mod:`~sassi_bench.calibrate.pixel_validity`); :func:`decode_correspondences` pairs
the two axes.

Frames can also be decoded one at a time, as they are captured or read back from a
session: :func:`sweep_reference` takes what every axis of a sweep shares (the dark,
blank and full frames) and an :class:`AxisDecoder` takes an axis's Gray pairs and phase
frames in any order, folding each Gray pair into the decode at once and keeping the
phase frames raw (their frame gains need all of them) until :meth:`AxisDecoder.finish`.
An axis so holds one Gray frame, its phase frames and the decode while it is decoded,
never the stacks of its frames as floats.

Coordinates follow the workbench convention: pixel centres at integers, arrays indexed
``[row, col]``; SLM pixel ``p`` spans ``p - 0.5 .. p + 0.5``.

Every pass over the pixels is a compiled loop
(:mod:`~sassi_bench.calibrate._frame_kernels`) that takes frames as uint16 or float,
subtracting the dark frame itself.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape, check_shape_equality
from sassi_bench.acquire.patterns import gray_bit_count
from sassi_bench.calibrate import _frame_kernels as _kernels
from sassi_bench.calibrate.frame_stacks import (
    dark_level,
    frame_stack,
    saturation_argument,
    subtract_dark,
)
from sassi_bench.calibrate.gray_decode import GrayAccumulator, check_block
from sassi_bench.calibrate.phase_decode import blur_from_modulation, fit_fringes, phase_solver
from sassi_bench.calibrate.pixel_validity import (
    REASONS,
    noise_floor,
    reason_counts,
    saturated,
    screen_outliers,
)
from sassi_bench.errors import ProcedureError, step_error

__all__ = [
    "AxisDecode",
    "AxisDecoder",
    "Correspondences",
    "SweepReference",
    "decode_axis",
    "decode_correspondences",
    "sweep_reference",
]

# Default border margin, in blur sigmas (plus half a pixel): a Gaussian spot truncated
# 2.5 sigma from its centre is pulled inwards by under 0.02 sigma.
_EDGE_SIGMAS = 2.5


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
        Pixels per outcome: ``"pixels"`` (all), then every name of
        :data:`~sassi_bench.calibrate.pixel_validity.REASONS`; a pixel is counted
        once, under the first reason that excludes it.
    reason
        Code of that first reason (H, W), an index into
        :data:`~sassi_bench.calibrate.pixel_validity.REASONS` (0 = valid).
    coarse
        The Gray-code block centre (H, W), for diagnostics.
    blur_sigma
        Line-spread sigma along the axis (SLM px), estimated from the median
        modulation depth of the decodable pixels (see
        :func:`~sassi_bench.calibrate.phase_decode.blur_from_modulation`).
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


def _median_blur(depth: NDArray[np.float64], usable: NDArray[np.bool_], period: float) -> float:
    """Blur sigma of the median modulation depth over ``usable`` pixels (0 if none)."""
    if not np.any(usable):
        return 0.0
    return float(blur_from_modulation(np.median(depth[usable]), period))


def _check_geometry(length: int, block: int, period: float, tolerance: float, step: str) -> int:
    """The Gray/phase geometry of one axis; returns its number of Gray bits."""
    check_block(block, step)
    if isinstance(length, bool) or not isinstance(length, (int, np.integer)) or length < 1:
        raise ProcedureError(
            step_error(
                step,
                f"length {length!r} is not a positive integer",
                "pass the SLM's width (axis x) or height (axis y) in pixels",
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
    return gray_bit_count(length, block)


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
    fix = "pass frames of one camera, all of the same shape"
    names = ("gray_positive", "gray_negative")
    check_shape_equality(pos, neg, step=step, names=names, fix=fix)
    check_shape(fringes, ("N", *shape), step=step, name="phase", expected_for="the frames", fix=fix)
    check_shape(blank, shape, step=step, name="blank", expected_for="the frames", fix=fix)
    check_shape(full, shape, step=step, name="full", expected_for="the frames", fix=fix)
    check_block(block, step)
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
    _check_geometry(length, block, period, tolerance, step)


@dataclass(frozen=True, eq=False)
class SweepReference:
    """What every axis of one sweep shares: the dark level and the pixels excluded before
    any pattern is decoded.

    Attributes
    ----------
    dark
        The dark frame (H, W) or scalar black level, float32.
    is_dark
        Pixels with too little light to decode (H, W): the ``dark`` reason.
    clipped
        Pixels the blank or full frame saturates (H, W).
    """

    dark: NDArray[np.float32]
    is_dark: NDArray[np.bool_]
    clipped: NDArray[np.bool_]

    @property
    def shape(self) -> tuple[int, int]:
        """The frames' (H, W)."""
        return self.is_dark.shape


def sweep_reference(
    blank: ArrayLike,
    full: ArrayLike,
    *,
    dark: ArrayLike | None = None,
    saturation_level: float | None = 65535,
    min_signal: float | None = None,
    min_relative_signal: float = 0.05,
) -> SweepReference:
    """The dark, blank and full frames of a sweep, as every axis's decode needs them.

    Parameters
    ----------
    blank, full
        Frames (H, W) with the SLM fully closed and fully open.
    dark
        Dark frame (light off) (H, W) or scalar black level.
    saturation_level
        Raw value at which the camera saturates; ``None`` skips the check.
    min_signal, min_relative_signal
        A pixel is ``dark`` when ``full - blank`` (dark-subtracted) is at most
        ``min_signal`` (default ten times the dark frame's robust noise, 0 for a scalar
        ``dark``) or ``min_relative_signal`` of the 99.5th percentile.

    Returns
    -------
    SweepReference

    Examples
    --------
    >>> ref = sweep_reference(np.full((1, 3), 10.0), np.array([[10.0, 500.0, 1000.0]]))
    >>> ref.is_dark.tolist(), ref.clipped.tolist()
    ([[True, False, False]], [[False, False, False]])
    """
    step = "structured-light decoding"
    blank_raw, full_raw = np.asarray(blank), np.asarray(full)
    fix = "pass frames of one camera, all of the same shape"
    check_shape(full_raw, blank_raw.shape, step=step, name="full", expected_for="blank", fix=fix)
    dark_arr = dark_level(dark, blank_raw.shape, step)
    signal = subtract_dark(full_raw, dark_arr) - subtract_dark(blank_raw, dark_arr)
    floor = noise_floor(dark_arr) if min_signal is None else float(min_signal)
    bright = float(np.percentile(signal, 99.5)) if signal.size else 0.0
    floor = max(floor, min_relative_signal * bright)
    is_dark = ~(signal > floor)
    clipped = saturated([full_raw[None], blank_raw[None]], saturation_level)
    return SweepReference(dark_arr, is_dark, clipped)


class AxisDecoder:
    """Decode one SLM axis from its frames as they come: Gray pairs, then phase frames.

    Each Gray bit is folded into the decode when both its frames are in (the first is
    kept until its inverse arrives); phase frames are kept raw, in their own dtype, until
    :meth:`finish` fits the fringes with their frame gains. Frames may come in any order.

    Parameters
    ----------
    reference
        The sweep's dark level and excluded pixels (:func:`sweep_reference`).
    length, block, period, shifts, saturation_level, edge_margin, min_modulation,
    min_margin, tolerance, max_jump
        As for :func:`decode_axis`.
    phase_steps
        Phase frames of the axis (their shifts default to ``s * period // phase_steps``).

    Examples
    --------
    >>> from sassi_bench.acquire.patterns import gray_bit_count, render_pattern
    >>> from sassi_bench.calibrate.grey_response import sinusoid_profile
    >>> def show(**d):  # a noiseless camera that sees the SLM pixel for pixel
    ...     return 10.0 + 1000.0 * render_pattern(d, (2, 64)) / 255.0
    >>> ref = sweep_reference(show(kind="blank"), show(kind="full"), dark=10.0)
    >>> decoder = AxisDecoder(ref, length=64, phase_steps=8)
    >>> for b in range(gray_bit_count(64, 8)):
    ...     for inverse in (False, True):
    ...         frame = show(kind="gray", axis="x", bit=b, block=8, inverse=inverse)
    ...         decoder.add_gray(b, inverse, frame)
    >>> for s in range(8):
    ...     profile = sinusoid_profile(16)
    ...     decoder.add_phase(s, show(kind="periodic", axis="x", profile=profile, shift=2 * s))
    >>> axis = decoder.finish()
    >>> bool(np.nanmax(np.abs(axis.coord - np.arange(64))) < 0.02), axis.counts["valid"]
    (True, 124)
    """

    step = "structured-light decoding"

    def __init__(
        self,
        reference: SweepReference,
        *,
        length: int,
        phase_steps: int,
        block: int = 8,
        period: int = 16,
        shifts: Sequence[float] | None = None,
        saturation_level: float | None = 65535,
        edge_margin: float | None = None,
        min_modulation: float = 0.25,
        min_margin: float = 0.2,
        tolerance: float = 2.0,
        max_jump: float = 0.5,
    ) -> None:
        self.bits = _check_geometry(length, block, period, tolerance, self.step)
        self.reference, self.length, self.block, self.period = reference, length, block, period
        self.edge_margin, self.min_modulation = edge_margin, min_modulation
        self.min_margin, self.tolerance, self.max_jump = min_margin, tolerance, max_jump
        self.saturation = saturation_argument(saturation_level)
        if phase_steps < 3:
            raise ProcedureError(
                step_error(
                    self.step,
                    f"{phase_steps} phase frames cannot fit a fringe",
                    "capture at least 3 phase-shifted frames per axis",
                )
            )
        self.phase_steps = int(phase_steps)
        if shifts is None:
            shifts = np.arange(self.phase_steps) * period // self.phase_steps
        shifts = np.asarray(shifts, dtype=np.float64)
        check_shape(
            shifts,
            (self.phase_steps,),
            step="phase decoding",
            name="shifts",
            expected_for=f"{self.phase_steps} frames",
            fix="pass one shift per frame",
        )
        self.solver = phase_solver(shifts, float(period), "phase decoding")
        self.gray = GrayAccumulator(
            reference.shape, self.bits, block, dark=reference.dark,
            saturation_level=saturation_level, step=self.step,
        )  # fmt: skip
        self._waiting: dict[int, tuple[bool, NDArray]] = {}  # bit -> first frame of its pair
        self._phase: NDArray | None = None
        self._phase_seen: set[int] = set()

    def _frame(self, frame: ArrayLike, name: str) -> NDArray:
        arr = np.asarray(frame)
        check_shape(
            arr, self.reference.shape, step=self.step, name=name, expected_for="the frames",
            fix="pass frames of one camera, all of the same shape",
        )  # fmt: skip
        return arr

    def add_gray(self, bit: int, inverse: bool, frame: ArrayLike) -> None:
        """Take Gray bit ``bit``'s frame (``inverse``: of the inverse pattern)."""
        arr = self._frame(frame, "gray frame")
        waiting = self._waiting.get(bit)
        if waiting is None:
            if bit in self.gray.seen:
                raise ProcedureError(
                    step_error(self.step, f"Gray bit {bit} given twice", "pass each frame once")
                )
            self._waiting[bit] = (bool(inverse), arr)  # kept, not copied, until its pair
            return
        first_inverse, first = waiting
        if first_inverse == bool(inverse):
            raise ProcedureError(
                step_error(
                    self.step,
                    f"two {'inverse' if inverse else 'positive'} frames of Gray bit {bit}",
                    "pass each bit's frame and its inverse's once",
                )
            )
        del self._waiting[bit]
        positive, negative = (arr, first) if first_inverse else (first, arr)
        self.gray.add(bit, positive, negative)

    def add_phase(self, step: int, frame: ArrayLike) -> None:
        """Take the phase frame of shift number ``step`` (0 .. phase_steps - 1)."""
        arr = self._frame(frame, "phase frame")
        if not 0 <= step < self.phase_steps or step in self._phase_seen:
            raise ProcedureError(
                step_error(
                    self.step,
                    f"phase frame {step} given twice or not one of {self.phase_steps}",
                    "pass each phase frame once",
                )
            )
        if self._phase is None:
            self._phase = np.empty((self.phase_steps, *arr.shape), dtype=arr.dtype)
        self._phase[step] = arr
        self._phase_seen.add(step)
        if self.saturation == self.saturation:
            _kernels.saturation_test(arr, self.saturation, self.gray.clipped)

    @property
    def complete(self) -> bool:
        """Whether every Gray pair and phase frame is in."""
        return len(self.gray.seen) == self.bits and len(self._phase_seen) == self.phase_steps

    def finish(self) -> AxisDecode:
        """Fit the fringes, unwrap them and test every pixel (:class:`AxisDecode`)."""
        if not self.complete:
            raise ProcedureError(
                step_error(
                    self.step,
                    f"{len(self.gray.seen)} of {self.bits} Gray bits (with their inverses) "
                    f"and {len(self._phase_seen)} of {self.phase_steps} phase frames given",
                    "pass every frame of the axis before finishing it",
                )
            )
        ref = self.reference
        fringe = fit_fringes(self._phase, self.period, self.solver, ref.dark, skip=ref.is_dark)
        self._phase = None
        index = _kernels.gray_index(self.gray.word, self.bits)
        shape = ref.shape
        # The unwrapped coordinate and the modulation depth replace the fringe's position
        # and amplitude in place (each pixel reads its own first).
        coord, depth, coarse = fringe.coord, fringe.modulation, np.empty(shape)
        reason = np.empty(shape, dtype=np.uint8)
        _kernels.axis_reasons(
            ref.is_dark, ref.clipped | self.gray.clipped, fringe.modulation, fringe.offset,
            self.gray.second, fringe.coord, index, self.block, float(self.period),
            float(self.min_modulation), float(self.min_margin),
            self.period / 2 - self.tolerance, coord, coarse, depth, reason,
        )  # fmt: skip
        del fringe, index
        # The blur from the pixels that are lit, unsaturated and modulated (reasons 0, 4, 5).
        usable = (reason == 0) | (reason == REASONS.index("ambiguous_gray"))
        usable |= reason == REASONS.index("disagreement")
        blur = _median_blur(depth, usable, self.period)
        del usable
        margin = 0.5 + _EDGE_SIGMAS * blur if self.edge_margin is None else float(self.edge_margin)
        _kernels.edge_reasons(coord, reason, margin - 0.5, self.length - 0.5 - margin)
        screen_outliers(coord, reason, self.max_jump)
        valid = reason == 0
        coord[~valid] = np.nan
        return AxisDecode(
            coord=coord,
            valid=valid,
            modulation=depth,
            counts=reason_counts(reason),
            reason=reason,
            coarse=coarse,
            blur_sigma=blur,
            edge_margin=margin,
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
        (:func:`~sassi_bench.calibrate.phase_decode.blur_from_modulation`).
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
    pos = frame_stack(gray_positive, step, "gray_positive")
    neg = frame_stack(gray_negative, step, "gray_negative")
    fringes = frame_stack(phase, step, "phase", minimum=3)
    blank_raw, full_raw = np.asarray(blank), np.asarray(full)
    _check_axis_inputs(pos, neg, fringes, blank_raw, full_raw, length, block, period, tolerance)
    reference = sweep_reference(
        blank_raw, full_raw, dark=dark, saturation_level=saturation_level,
        min_signal=min_signal, min_relative_signal=min_relative_signal,
    )  # fmt: skip
    decoder = AxisDecoder(
        reference, length=length, phase_steps=fringes.shape[0], block=block, period=period,
        shifts=shifts, saturation_level=saturation_level, edge_margin=edge_margin,
        min_modulation=min_modulation, min_margin=min_margin, tolerance=tolerance,
        max_jump=max_jump,
    )  # fmt: skip
    for bit, (positive, negative) in enumerate(zip(pos, neg, strict=True)):
        decoder.add_gray(bit, False, positive)
        decoder.add_gray(bit, True, negative)
    for s, frame in enumerate(fringes):
        decoder.add_phase(s, frame)
    return decoder.finish()


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
        ``"pixels"``, then every name of :data:`~sassi_bench.calibrate.pixel_validity.REASONS`: each
        pixel counted once, under the first reason (in that order) that excludes it on
        either axis.
    reason
        That reason's code (H, W), an index into
        :data:`~sassi_bench.calibrate.pixel_validity.REASONS`.
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
    check_shape_equality(
        x_axis.coord,
        y_axis.coord,
        step=step,
        names=("the x axis", "the y axis"),
        fix="decode both axes from frames of the same camera",
    )
    rx, ry = x_axis.reason, y_axis.reason
    reason = np.where((rx == 0) | ((ry != 0) & (ry < rx)), ry, rx).astype(np.uint8)
    valid = reason == 0
    counts = reason_counts(reason)
    if not np.any(valid):
        raise ProcedureError(
            step_error(
                step,
                f"no pixel was decoded on both axes (counts {counts})",
                "check the light, the exposure (dark or saturated frames) and the pattern order",
            )
        )
    rows, cols = np.divmod(np.flatnonzero(valid), valid.shape[1])  # nonzero's, in half the time
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
