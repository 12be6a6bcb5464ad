"""The laser sweep decoded frame by frame, as it is captured or read back.

:class:`SweepStream` takes the frames of a sweep session
(:func:`~sassi_bench.acquire.spectral_plans.sweep_plan`) one at a time, in plan order
(a :class:`~sassi_bench.acquire.frame_feed.FrameFeed` gives them so), and keeps per
laser only what the decoding needs: the dark, blank and full frames' means, one Gray
frame waiting for its inverse, the phase frames of the axis being decoded (raw), the
decoded axis before it, and the pinhole frames' sum. Each axis is decoded
(:class:`~sassi_bench.calibrate.structured_light.AxisDecoder`) as soon as its last frame
is in, and a laser's correspondences as soon as both axes are, so the stream never holds
the stacks of an axis's frames as floats. The result is the same whether the frames came
from the capture or from the session afterwards: the same code sees the same frames in the
same order.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.plan import Plan
from sassi_bench.calibrate import _frame_kernels
from sassi_bench.calibrate.structured_light import AxisDecoder, SweepReference, sweep_reference
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["DecodedSweep", "PinholeSignal", "SweepDecode", "SweepStream", "lit_pixels"]

#: Roles whose frames are averaged per laser.
_MEANS = ("dark", "blank", "full", "blur-blank", "pinholes")


@dataclass(frozen=True, eq=False)
class SweepDecode:
    """One laser's decoded correspondences, before the field fit.

    Attributes
    ----------
    camera_x, camera_y
        Camera column and row of every decoded pixel (N,).
    slm_u, slm_v
        Their SLM column and row (N,).
    valid_fraction
        Share of the camera pixels the open SLM lights that were decoded.
    counts
        Decoding diagnostics, stored in the bundle's quality section: per-axis reason
        counts (``x_valid``, ``y_dark`` ...) for structured light; skipped frames,
        pixels outside the SLM and the line fits' RMS (``x_line_fit_rms_slm_px``) for
        the line sweep.
    """

    camera_x: NDArray[np.float64]
    camera_y: NDArray[np.float64]
    slm_u: NDArray[np.float64]
    slm_v: NDArray[np.float64]
    valid_fraction: float
    counts: dict[str, Any]


@dataclass(frozen=True, eq=False)
class PinholeSignal:
    """A laser's pinhole (blur) frames: their mean minus the blank frame's, and the pixels
    any of them saturates."""

    signal: NDArray[np.float32]
    saturated: NDArray[np.bool_]


@dataclass(frozen=True)
class DecodedSweep:
    """What a sweep session's frames gave: per laser, its correspondences (structured
    sweeps) and its pinhole signal."""

    decodes: dict[float, SweepDecode] = field(default_factory=dict)
    pinholes: dict[float, PinholeSignal] = field(default_factory=dict)


def lit_pixels(full: NDArray, blank: NDArray) -> NDArray[np.bool_]:
    """Camera pixels the open SLM lights (the denominator of the valid fraction): the
    full frame above the blank by a tenth of the bright level (its 99.5th percentile).

    Examples
    --------
    >>> lit_pixels(np.array([[0.0, 50.0, 100.0]]), np.zeros((1, 3))).tolist()
    [[False, True, True]]
    """
    signal = full - blank
    return signal > 0.1 * np.percentile(signal, 99.5)


class _Mean:
    """A float32 running sum of frames (numpy's float32 mean along a stack, in order) and
    the saturated pixels of any of them."""

    def __init__(self, frame: NDArray, saturation: float) -> None:
        self.total = np.zeros(frame.shape, dtype=np.float32)
        self.count = 0
        self.clipped = np.zeros(frame.shape, dtype=bool)
        self.saturation = saturation

    def add(self, frame: NDArray) -> None:
        _frame_kernels.accumulate(frame, self.total)
        _frame_kernels.saturation_test(frame, self.saturation, self.clipped)
        self.count += 1

    def mean(self) -> NDArray[np.float32]:
        return self.total / np.float32(self.count)


@dataclass
class _Laser:
    """One laser's state while its frames come in."""

    wavelength: float
    expected: dict[str, int]  # frames per averaged role
    means: dict[str, _Mean] = field(default_factory=dict)
    reference: SweepReference | None = None
    lit: NDArray[np.bool_] | None = None
    axes: dict[str, AxisDecoder] = field(default_factory=dict)
    done: dict[str, tuple] = field(default_factory=dict)  # axis -> (coord, valid, counts)


class SweepStream:
    """Decode a sweep session's frames as they come, in plan order.

    Parameters
    ----------
    plan
        The sweep session's plan.
    procedure
        The spectral-calibration procedure the sweep was captured with (its ``sweep``
        section: Gray block, fringe period, minimum modulation).
    slm_shape
        SLM (height, width).
    saturation
        Raw value at which the spectral camera saturates.
    lasers
        Decode only these lasers' frames (default: all).
    pinholes
        Also average the pinhole (blur) frames.

    Examples
    --------
    Not run here (it needs captured sessions)::

        stream = SweepStream(session.plan, proc, rig.slm.shape, 65535)
        for i in sorted(session.completed):
            stream.add(i, session.read_frame(i))
        stream.result().decodes[532.0].valid_fraction
        # 0.98
    """

    def __init__(
        self,
        plan: Plan,
        procedure: Mapping[str, Any],
        slm_shape: tuple[int, int],
        saturation: float,
        lasers: set[float] | None = None,
        pinholes: bool = True,
    ) -> None:
        sweep = procedure["sweep"]
        self.structured = sweep["mode"] == "structured"
        self.block = int(sweep.get("gray_block_px", 8))
        self.period = int(sweep.get("phase_period_px", 16))
        self.min_modulation = float(sweep.get("min_modulation", 0.2))
        self.slm_shape = tuple(slm_shape)
        self.saturation = float(saturation)
        self._lasers: dict[float, _Laser] = {}
        self._decoded = DecodedSweep()
        self._role: dict[int, tuple] = {}  # step -> what it is
        self._phase_counts: dict[tuple[float, str], int] = {}
        position: dict[tuple, int] = {}
        for i, step in enumerate(plan.steps):
            tags = step.tags
            role, laser = tags.get("role"), tags.get("laser")
            if laser is None or (lasers is not None and float(laser) not in lasers):
                continue
            laser = float(laser)
            state = self._lasers.setdefault(laser, _Laser(laser, dict.fromkeys(_MEANS, 0)))
            if role in _MEANS and (pinholes or role not in ("blur-blank", "pinholes")):
                state.expected[role] += 1
                self._role[i] = (laser, role)
            elif role in ("gray", "phase") and self.structured:
                axis = tags["axis"]
                inverse = bool(tags.get("inverse", False))
                key = (laser, role, axis, inverse)
                # A frame's bit (or phase shift) is its place among its kind, in plan order.
                self._role[i] = (laser, role, axis, inverse, position.get(key, 0))
                position[key] = position.get(key, 0) + 1
                if role == "phase":
                    self._phase_counts[(laser, axis)] = position[key]

    @property
    def steps(self) -> list[int]:
        """The plan steps the stream takes."""
        return sorted(self._role)

    def add(self, index: int, frame: NDArray[Any]) -> None:
        """Take step ``index``'s frame."""
        what = self._role.get(index)
        if what is None:
            return
        laser = self._lasers[what[0]]
        if len(what) == 2:
            role = what[1]
            if role not in laser.means:
                laser.means[role] = _Mean(np.asarray(frame), self.saturation)
            laser.means[role].add(frame)
            self._pinhole_signal(laser)
            return
        _, role, axis, inverse, place = what
        decoder = self._decoder(laser, axis)
        if role == "gray":
            decoder.add_gray(place, inverse, frame)
        else:
            decoder.add_phase(place, frame)
        if decoder.complete:
            decoded = decoder.finish()
            laser.done[axis] = (decoded.coord, decoded.valid, decoded.counts)
            del laser.axes[axis], decoded
            if {"x", "y"} <= set(laser.done):
                self._decoded.decodes[laser.wavelength] = _correspondences(laser)
                # What the laser's decode needed goes; the pinhole frames' sums stay.
                laser.done.clear()
                laser.reference = laser.lit = None
                for role in ("dark", "blank", "full"):
                    laser.means.pop(role, None)

    def _pinhole_signal(self, laser: _Laser) -> None:
        """The pinhole signal once the laser's pinhole and blur-blank frames are all in."""
        pinholes, blank = laser.means.get("pinholes"), laser.means.get("blur-blank")
        if (
            pinholes is not None
            and blank is not None
            and pinholes.count == laser.expected["pinholes"]
            and blank.count == laser.expected["blur-blank"]
        ):
            self._decoded.pinholes[laser.wavelength] = PinholeSignal(
                pinholes.mean() - blank.mean(), pinholes.clipped
            )
            del laser.means["pinholes"], laser.means["blur-blank"]

    def _reference(self, laser: _Laser) -> SweepReference:
        if laser.reference is None:
            missing = [
                r for r in ("dark", "blank", "full")
                if laser.means.get(r) is None or laser.means[r].count < laser.expected[r]
            ]  # fmt: skip
            if missing:
                raise ProcedureError(
                    step_error(
                        f"sweep decoding at {laser.wavelength:g} nm",
                        f"its pattern frames came before its {', '.join(missing)} frame(s)",
                        "capture the sweep plan's steps in order",
                    )
                )
            dark, blank, full = (laser.means[r].mean() for r in ("dark", "blank", "full"))
            laser.reference = sweep_reference(
                blank, full, dark=dark, saturation_level=self.saturation
            )
            laser.lit = lit_pixels(full, blank)
        return laser.reference

    def _decoder(self, laser: _Laser, axis: str) -> AxisDecoder:
        decoder = laser.axes.get(axis)
        if decoder is None:
            if axis in laser.done:
                raise ProcedureError(
                    step_error(
                        f"sweep decoding at {laser.wavelength:g} nm",
                        f"a frame of axis {axis} came after the axis was decoded",
                        "pass each frame once",
                    )
                )
            length = self.slm_shape[1] if axis == "x" else self.slm_shape[0]
            decoder = laser.axes[axis] = AxisDecoder(
                self._reference(laser),
                length=length,
                phase_steps=self._phase_counts.get((laser.wavelength, axis), 0),
                block=self.block,
                period=self.period,
                saturation_level=self.saturation,
                min_modulation=self.min_modulation,
            )
        return decoder

    def result(self) -> DecodedSweep:
        """Every laser's decode (lasers with both axes decoded) and pinhole signal (lasers
        with all their pinhole frames)."""
        return self._decoded


def _correspondences(laser: _Laser) -> SweepDecode:
    x_coord, x_valid, x_counts = laser.done["x"]
    y_coord, y_valid, y_counts = laser.done["y"]
    valid = x_valid & y_valid
    lit = laser.lit
    flat = np.flatnonzero(valid)  # nonzero's rows and columns, in half the time
    rows, cols = np.divmod(flat, valid.shape[1])
    counts = {f"x_{k}": v for k, v in x_counts.items()}
    counts.update({f"y_{k}": v for k, v in y_counts.items()})
    return SweepDecode(
        camera_x=cols.astype(np.float64),
        camera_y=rows.astype(np.float64),
        slm_u=x_coord.ravel()[flat],
        slm_v=y_coord.ravel()[flat],
        valid_fraction=float((valid & lit).sum() / max(lit.sum(), 1)),
        counts=counts,
    )
