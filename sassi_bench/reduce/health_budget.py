"""How many health-check frames: the stopping rule of the health check and its record.

The health check's verdict rests on the map of the lamp streaks' shift over the field
(:func:`~sassi_bench.calibrate.streak_shift.shift_field_map`), which states its 1-sigma
(``ShiftMap.sigma_px``, the worst over the field). A shift of 0.05 px measured at
+-0.05 px says nothing about a 0.1 px tolerance, so the check measures until confident:
``frames`` pinhole frames first, then, while the map's 1-sigma is above
``tolerances.shift_sigma_px``, the frames the lamp step's rule asks for
(:func:`~sassi_bench.reduce.lamp_budget.next_frames`), at most ``max_frames``. The rule
is a pure function of the frames measured, so a resumed check replays it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from sassi_bench.reduce.batch_record import BatchRecord
from sassi_bench.reduce.lamp_budget import frames_needed, next_frames

__all__ = [
    "DEFAULT_MAX_FRAMES",
    "DEFAULT_TOLERANCE_PX",
    "ShiftBatch",
    "ShiftFrameRecord",
    "decide_shift_frames",
    "shift_frame_settings",
]

#: Pinhole frames the health check may take when the procedure names no budget.
DEFAULT_MAX_FRAMES = 8
#: The shift map's 1-sigma (camera px) when the procedure names none: a third of the
#: 0.1 px shift the check tolerates, so a shift at the tolerance is told from none.
DEFAULT_TOLERANCE_PX = 0.03


def shift_frame_settings(procedure: Mapping[str, Any]) -> tuple[int, int, float]:
    """The first batch, the budget (pinhole frames) and the tolerance (camera px).

    Examples
    --------
    >>> shift_frame_settings({"frames": 1, "max_frames": 6, "tolerances": {"shift_sigma_px": 0.02}})
    (1, 6, 0.02)
    >>> shift_frame_settings({"frames": 2, "tolerances": {}})
    (2, 8, 0.03)
    """
    first = int(procedure.get("frames", 1))
    budget = max(first, int(procedure.get("max_frames") or DEFAULT_MAX_FRAMES))
    tolerances = procedure.get("tolerances") or {}
    return first, budget, float(tolerances.get("shift_sigma_px") or DEFAULT_TOLERANCE_PX)


@dataclass(frozen=True)
class ShiftBatch:
    """One decision of the health check.

    Attributes
    ----------
    frames
        Pinhole frames measured when the decision was made.
    sigma_px
        The shift map's stated 1-sigma, worst over the field (camera px).
    shift_max_px
        The map's largest shift from those frames (camera px).
    next_frames
        Pinhole frames to have next; None when the check stops.
    outcome
        ``"more frames"``, ``"tolerance met"``, ``"budget spent"`` or ``"out of reach"``.
    """

    frames: int
    sigma_px: float
    shift_max_px: float
    next_frames: int | None
    outcome: str

    def to_json(self) -> dict[str, Any]:
        """The batch as JSON values."""
        return {
            "frames": self.frames,
            "sigma_px": self.sigma_px,
            "shift_max_px": self.shift_max_px,
            "next_frames": self.next_frames,
            "outcome": self.outcome,
        }


def decide_shift_frames(
    frames: int,
    sigma_px: float,
    shift_max_px: float,
    tolerance_px: float,
    budget: int,
    earlier: Sequence[ShiftBatch] = (),
) -> ShiftBatch:
    """Stop, or the pinhole frames to have next, from the shift map's stated 1-sigma (and
    the earlier batches', ``earlier``, which tell photons from a floor:
    :func:`~sassi_bench.reduce.lamp_budget.next_frames`).

    Examples
    --------
    >>> decide_shift_frames(1, 0.02, 0.01, 0.03, 8).outcome
    'tolerance met'
    >>> decide_shift_frames(1, 0.05, 0.01, 0.03, 8).next_frames  # 1 * (0.05 / 0.03)**2
    3
    """
    return ShiftBatch(
        frames,
        float(sigma_px),
        float(shift_max_px),
        *next_frames(
            frames,
            sigma_px,
            tolerance_px,
            budget,
            [(b.frames, b.sigma_px) for b in earlier],
        ),
    )


@dataclass(frozen=True)
class ShiftFrameRecord(BatchRecord):
    """What the health check took and why (its frames, outcome and batches as
    :class:`~sassi_bench.reduce.batch_record.BatchRecord` reads them).

    Attributes
    ----------
    batches
        Every decision, in order (the last one stopped).
    tolerance_px, budget
        The tolerance and the budget it worked to.
    """

    batches: tuple[ShiftBatch, ...]
    tolerance_px: float
    budget: int

    @property
    def sigma_px(self) -> float:
        """The shift map's 1-sigma at the end (camera px)."""
        return self.batches[-1].sigma_px

    def advice(self) -> str | None:
        """What would meet the tolerance when the step stopped short of it (None
        otherwise).

        Examples
        --------
        >>> last = ShiftBatch(8, 0.04, 0.02, None, "budget spent")
        >>> print(ShiftFrameRecord((last,), 0.03, 8).advice())
        the shift map at +-0.040 px after 8 pinhole frames: take about 15 (set max_frames \
to 15 in the health-check procedure), or expose the lamp longer
        """
        if self.outcome not in ("budget spent", "out of reach"):
            return None
        if self.photon_limited() is False:
            return (
                f"the shift map at +-{self.sigma_px:.3f} px after {self.frames} pinhole "
                "frames: more frames will not do (its 1-sigma hardly fell with them): the "
                "pinholes' shifts scatter about the map more than their noise; raise "
                "field_degree, or recalibrate if the bench moved unevenly"
            )
        needed = frames_needed(self.frames, self.sigma_px, self.tolerance_px)
        return (
            f"the shift map at +-{self.sigma_px:.3f} px after {self.frames} pinhole frames: "
            f"take about {needed} (set max_frames to {needed} in the health-check "
            "procedure), or expose the lamp longer"
        )

    def note(self) -> str:
        """One line for the check's summary: what was taken and why.

        Examples
        --------
        >>> first = ShiftBatch(1, 0.05, 0.02, 3, "more frames")
        >>> last = ShiftBatch(3, 0.028, 0.015, None, "tolerance met")
        >>> print(ShiftFrameRecord((first, last), 0.03, 8).note())
        check frames: 3 pinhole frames (1, then 3): the shift map at +-0.028 px (1-sigma, \
worst over the field; tolerance 0.03 px): tolerance met
        """
        return self.with_advice(
            f"check frames: {self.frames} pinhole frame{'s' if self.frames != 1 else ''} "
            f"({self.taken()}): the shift map at "
            f"+-{self.sigma_px:.3f} px (1-sigma, worst over the field; tolerance "
            f"{self.tolerance_px:g} px): {self.outcome}"
        )

    def to_json(self) -> dict[str, Any]:
        """The record as JSON values."""
        return {
            "frames": self.frames,
            "budget": self.budget,
            "tolerance_px": self.tolerance_px,
            "outcome": self.outcome,
            "sigma_px": self.sigma_px,
            "batches": [b.to_json() for b in self.batches],
            "advice": self.advice(),
        }
