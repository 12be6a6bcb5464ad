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
from sassi_bench.calibrate.frame_stacks import dark_level, frame_stack, subtract_dark
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["PhaseDecode", "blur_from_modulation", "decode_phase", "unwrap"]

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
    dark_arr = dark_level(dark, stack.shape[1:], step)
    coef = _phase_coefficients(stack, dark_arr, solver)
    if normalise and count > 3:
        design = np.linalg.pinv(solver)
        gains = _frame_gains(stack, dark_arr, coef, solver, design)
        coef = _phase_coefficients(stack, dark_arr, solver / gains[None, :])
    theta = np.arctan2(coef[2], coef[1])
    coord = np.mod(theta * (period / (2.0 * np.pi)), period)
    coord[coord >= period] = 0.0  # mod of a tiny negative number can round up to period
    return PhaseDecode(coord, np.hypot(coef[1], coef[2]), coef[0])


def _phase_coefficients(
    stack: NDArray, dark: NDArray[np.float32], solver: NDArray[np.float64]
) -> NDArray[np.float64]:
    """Offset and quadrature amplitudes (3, H, W): ``solver`` applied to the frames."""
    coef = np.zeros((3, *stack.shape[1:]), dtype=np.float64)
    for s, raw in enumerate(stack):
        frame = subtract_dark(raw, dark)
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
