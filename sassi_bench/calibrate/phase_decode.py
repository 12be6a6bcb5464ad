"""Decode phase-shifted fringes into a sub-pixel position within the period.

``S`` frames of transmission ``t_s(p) = 0.5 + 0.5 cos(2 pi (p - shift_s) / period)``
along one SLM axis give every camera pixel's position within a period to a small
fraction of a pixel; a coarse absolute estimate (the Gray-code block,
:mod:`sassi_bench.calibrate.gray_decode`) picks the period (:func:`unwrap`). The fringes'
modulation depth also measures the blur (:func:`blur_from_modulation`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape
from sassi_bench.calibrate import _frame_kernels as _kernels
from sassi_bench.calibrate.frame_stacks import dark_argument, dark_level, frame_stack
from sassi_bench.errors import ProcedureError, step_error

__all__ = [
    "PhaseDecode",
    "blur_from_modulation",
    "decode_phase",
    "fit_fringes",
    "phase_solver",
    "unwrap",
]

# Joint fit of per-frame gains (see _frame_gains): pixels sampled and iterations at most.
_GAIN_PIXELS = 50_000
_GAIN_ITERATIONS = 200


@dataclass(frozen=True, eq=False)
class PhaseDecode:
    """The fitted fringe of every camera pixel.

    Attributes
    ----------
    coord
        ``period * theta / (2 pi)`` wrapped into ``[0, period)`` (H, W): the position
        within the period.
    modulation
        Fringe amplitude ``B`` (H, W), in frame units.
    offset
        Mean level ``A`` (H, W), dark-subtracted.
    """

    coord: NDArray[np.float64]
    modulation: NDArray[np.float64]
    offset: NDArray[np.float64]


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
) -> PhaseDecode:
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
    PhaseDecode
        Position within the period, fringe amplitude and mean level of every pixel.

    Examples
    --------
    >>> p = np.arange(32.0)
    >>> frames = np.stack([0.5 + 0.5 * np.cos(2 * np.pi * (p - 2 * s) / 16) for s in range(8)])
    >>> fringe = decode_phase(frames[:, None, :], period=16)
    >>> np.round(fringe.coord[0, [0, 1, 15, 17]], 6).tolist()
    [0.0, 1.0, 15.0, 1.0]
    >>> round(float(fringe.modulation[0, 0]), 6)
    0.5
    """
    step = "phase decoding"
    stack = frame_stack(frames, step, "phase frames", minimum=3)
    if not np.isfinite(period) or period <= 0:
        raise ProcedureError(step_error(step, f"period {period!r} is not positive", "use e.g. 16"))
    count = stack.shape[0]
    if shifts is None:
        shifts = np.arange(count) * period // count
    shifts = np.asarray(shifts, dtype=np.float64)
    check_shape(
        shifts,
        (count,),
        step=step,
        name="shifts",
        expected_for=f"{count} frames",
        fix="pass one shift per frame",
    )
    solver = _phase_solver(shifts, float(period), step)
    return fit_fringes(stack, period, solver, dark_level(dark, stack.shape[1:], step), normalise)


def fit_fringes(
    stack: NDArray,
    period: float,
    solver: NDArray[np.float64],
    dark: NDArray[np.float32],
    normalise: bool = True,
    skip: NDArray[np.bool_] | None = None,
) -> PhaseDecode:
    """:func:`decode_phase` on checked arguments: raw frames (S, H, W) in any dtype, the
    least-squares solver (3, S) of their shifts and a :func:`dark_level`; ``skip`` marks
    pixels whose position is not needed (left at 0, e.g. pixels too dark to decode).

    Each pass reads every frame once per pixel (compiled): one for the frame gains'
    pixels, one for the fit.

    Examples
    --------
    >>> p = np.arange(16.0)
    >>> frames = np.stack([1 + np.cos(2 * np.pi * (p - 4 * s) / 16) for s in range(4)])
    >>> solver = phase_solver(np.arange(4) * 4.0, 16)
    >>> fringe = fit_fringes(frames[:, None, :], 16, solver, np.float32(0.0))
    >>> np.round(fringe.coord[0, [0, 5]], 6).tolist()
    [0.0, 5.0]
    """
    count = stack.shape[0]
    dark_arr, dark_map = dark_argument(dark)
    shape = stack.shape[1:]
    if normalise and count > 3:
        usable = np.empty(shape, dtype=bool)
        _kernels.phase_usable(stack, dark_arr, dark_map, solver, usable)
        gains = _frame_gains(stack, dark, usable, solver, np.linalg.pinv(solver))
        solver = solver / gains[None, :]
    offset, coord, modulation = (np.empty(shape) for _ in range(3))
    use_skip = skip is not None
    skip = np.zeros((1, 1), dtype=bool) if skip is None else np.asarray(skip, dtype=bool)
    _kernels.phase_fit(
        stack, dark_arr, dark_map, solver, float(period), skip, use_skip, offset, coord,
        modulation,
    )  # fmt: skip
    return PhaseDecode(coord, modulation, offset)


def phase_solver(shifts: ArrayLike, period: float, step: str = "phase decoding") -> NDArray:
    """The least-squares solver (3, S) for the offset and quadrature amplitudes of frames
    at pattern ``shifts`` (px) of a fringe of ``period`` px.

    Examples
    --------
    >>> phase_solver([0, 4, 8, 12], 16).shape
    (3, 4)
    """
    return _phase_solver(np.asarray(shifts, dtype=np.float64), float(period), step)


def _frame_gains(
    stack: NDArray,
    dark: NDArray[np.float32],
    usable: NDArray[np.bool_],
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
    from all pixels) on a regular subsample of the well-modulated pixels (``usable``:
    positive offset, amplitude over a fifth of it, in a fit with equal gains).
    """
    # The flat indices, then rows and columns of the subsample only (``nonzero`` would make
    # two index arrays of the whole frame).
    flat = np.flatnonzero(usable)
    count = stack.shape[0]
    if flat.size < 100:
        return np.ones(count)
    stride = max(1, flat.size // _GAIN_PIXELS)
    rows, cols = np.divmod(flat[::stride], usable.shape[1])
    dark_at = dark if dark.ndim == 0 else dark[rows, cols]
    frames = np.stack([np.asarray(raw[rows, cols], dtype=np.float64) - dark_at for raw in stack])
    # With F the (S, N) frames, G = F F^T and the fit's projector P = design @ solver, the
    # model of frames divided by the gains g is M = P diag(1/g) F: each gain's update
    # sum_n F_sn M_sn / sum_n M_sn^2 needs only G (S x S), so an iteration costs S^3.
    gram = frames @ frames.T
    projector = design @ solver
    gains = np.ones(count)
    for _ in range(_GAIN_ITERATIONS):
        scaled = projector / gains[None, :]  # P diag(1/g)
        new = np.sum(gram * scaled, axis=1) / np.einsum("st,tu,su->s", scaled, gram, scaled)
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
