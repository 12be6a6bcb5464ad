"""How many lamp frames: the stopping rule of the lamp step and the record of what it took.

The lamp frames anchor every laser's wavelength; how well depends on photons (faint lines,
a noisy camera) and on the rig's dispersion (lines that blend). The lamp step therefore
measures in batches: after each, the anchored fit states every laser's 1-sigma from the
frames taken so far, and :func:`decide_lamp_frames` says whether to stop (every laser
within ``tolerances.laser_wavelength_sigma_nm``, or ``lamps.max_frames`` spent) or how
many frames per lamp to have next. A photon-limited uncertainty falls as one over the
square root of the frames, so the next batch aims at the frames that would meet the
tolerance, within the budget. The rule is a pure function of what was measured, so a
resumed session replays the same decisions on the same frames and captures none twice.
:func:`next_frames` is that rule alone, shared with the blur step
(:mod:`~sassi_bench.reduce.blur_budget`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from sassi_bench.reduce.batch_record import BatchRecord

__all__ = [
    "DEFAULT_MAX_FRAMES",
    "LampBatch",
    "LampFrameRecord",
    "decide_lamp_frames",
    "frames_needed",
    "lamp_frame_settings",
    "next_frames",
]

#: Pinhole frames per lamp the lamp step may take when the procedure names no budget.
DEFAULT_MAX_FRAMES = 16
#: A laser needing more than this many times the budget is not a matter of frames: its
#: lamp lines blend at the rig's dispersion or are missing near it.
HOPELESS_FACTOR = 4.0


def lamp_frame_settings(procedure: Mapping[str, Any]) -> tuple[int, int, float]:
    """The first batch, the budget (pinhole frames per lamp) and the tolerance (nm).

    Examples
    --------
    >>> lamp_frame_settings({"lamps": {"frames": 4}, "tolerances": {}})
    (4, 16, 0.5)
    >>> lamp_frame_settings({"lamps": {"frames": 4, "max_frames": 2}, "tolerances": {}})
    (2, 2, 0.5)
    """
    lamps = procedure.get("lamps") or {}
    budget = int(lamps.get("max_frames") or DEFAULT_MAX_FRAMES)
    first = min(int(lamps.get("frames", 4)), budget)
    tolerance = float((procedure.get("tolerances") or {}).get("laser_wavelength_sigma_nm", 0.5))
    return first, budget, tolerance


@dataclass(frozen=True)
class LampBatch:
    """One decision of the lamp step.

    Attributes
    ----------
    frames
        Pinhole frames per lamp measured when the decision was made.
    sigma_nm
        Every laser's 1-sigma (nm), by label, as the lamps measure it from those frames.
    next_frames
        Frames per lamp to have next; None when the step stops.
    outcome
        ``"more frames"``, ``"tolerance met"`` or ``"budget spent"``.
    """

    frames: int
    sigma_nm: dict[float, float]
    next_frames: int | None
    outcome: str

    def to_json(self) -> dict[str, Any]:
        """The batch as JSON values (labels as strings)."""
        return {
            "frames": self.frames,
            "sigma_nm": {f"{k:g}": v for k, v in self.sigma_nm.items()},
            "next_frames": self.next_frames,
            "outcome": self.outcome,
        }


def decide_lamp_frames(
    frames: int, sigma_nm: Mapping[float, float], tolerance_nm: float, budget: int
) -> LampBatch:
    """Stop, or the frames per lamp to have next, from the uncertainty reached so far.

    Parameters
    ----------
    frames
        Pinhole frames per lamp measured.
    sigma_nm
        Every laser's 1-sigma (nm) from those frames, by label.
    tolerance_nm
        The 1-sigma every laser should reach.
    budget
        The most pinhole frames per lamp the step may take.

    Returns
    -------
    LampBatch

    Examples
    --------
    >>> decide_lamp_frames(4, {520.0: 0.2, 670.0: 0.4}, 0.5, 16).outcome
    'tolerance met'
    >>> decide_lamp_frames(4, {670.0: 0.6}, 0.5, 16).next_frames  # 4 * (0.6 / 0.5)**2
    6
    >>> decide_lamp_frames(16, {670.0: 0.6}, 0.5, 16).outcome
    'budget spent'
    """
    sigma = {float(k): float(v) for k, v in sigma_nm.items()}
    worst = max(sigma.values(), default=0.0)
    return LampBatch(frames, sigma, *next_frames(frames, worst, tolerance_nm, budget))


def next_frames(frames: int, sigma: float, tolerance: float, budget: int) -> tuple[int | None, str]:
    """The stopping rule of a step that measures until confident: the frames to have next
    (None: stop) and why, from the worst 1-sigma reached with ``frames`` frames.

    A photon-limited 1-sigma falls as one over the square root of the frames: the next
    batch aims at the frames that would meet the tolerance (at least one more), within
    the budget.

    Parameters
    ----------
    frames
        Frames measured.
    sigma
        The worst stated 1-sigma from them.
    tolerance
        The 1-sigma to reach, in ``sigma``'s unit.
    budget
        The most frames the step may take.

    Returns
    -------
    tuple
        ``(next frames or None, outcome)``, the outcome ``"more frames"``,
        ``"tolerance met"`` or ``"budget spent"``.

    Examples
    --------
    >>> next_frames(2, 0.08, 0.05, 8)
    (6, 'more frames')
    >>> next_frames(8, 0.08, 0.05, 8)
    (None, 'budget spent')
    """
    if frames < 1 or budget < 1:
        raise ValueError(f"frames ({frames}) and budget ({budget}) must be positive")
    if sigma <= tolerance:
        return None, "tolerance met"
    if frames >= budget:
        return None, "budget spent"
    wanted = frames_needed(frames, sigma, tolerance)
    return min(budget, max(wanted, frames + 1)), "more frames"


def frames_needed(frames: int, sigma: float, tolerance: float) -> int:
    """The frames at which a photon-limited 1-sigma, ``sigma`` after ``frames``, meets the
    tolerance.

    Examples
    --------
    >>> frames_needed(16, 0.6, 0.5)
    24
    """
    return math.ceil(frames * (sigma / tolerance) ** 2 - 1e-9)


@dataclass(frozen=True)
class LampFrameRecord(BatchRecord):
    """What the lamp step took and why: its batches, the outcome and, when the budget was
    spent, what would meet the tolerance (frames and outcome as
    :class:`~sassi_bench.reduce.batch_record.BatchRecord` reads them).

    Attributes
    ----------
    batches
        Every decision, in order (the last one stopped).
    tolerance_nm, budget
        The tolerance and the budget it worked to.
    exposures_s
        Exposure of each lamp's frames, by light name.
    max_exposure_s
        The longest exposure the procedure allows (``lamps.max_s``).
    """

    batches: tuple[LampBatch, ...]
    tolerance_nm: float
    budget: int
    exposures_s: dict[str, float]
    max_exposure_s: float

    @property
    def short_of(self) -> dict[float, float]:
        """The lasers above the tolerance at the end, with their 1-sigma (nm)."""
        last = self.batches[-1].sigma_nm
        return {k: v for k, v in last.items() if v > self.tolerance_nm}

    def advice(self) -> str | None:
        """What would meet the tolerance when the budget was spent (None otherwise).

        Examples
        --------
        >>> last = LampBatch(16, {670.0: 0.6}, None, "budget spent")
        >>> print(LampFrameRecord((last,), 0.5, 16, {"lamp:Ne": 0.4}, 10.0).advice())
        laser 670 nm at +-0.60 nm after 16 lamp frames: take about 24 lamp frames per lamp \
(set lamps.max_frames to 24 and capture the lamp frames under a new --session)
        """
        if self.outcome != "budget spent":
            return None
        worst = max(self.short_of.values())
        needed = frames_needed(self.frames, worst, self.tolerance_nm)
        lasers = ", ".join(f"laser {k:g} nm at +-{v:.2f} nm" for k, v in self.short_of.items())
        said = f"{lasers} after {self.frames} lamp frames: "
        capped = [k for k, t in self.exposures_s.items() if t >= 0.999 * self.max_exposure_s]
        if needed > HOPELESS_FACTOR * self.budget:
            return said + (
                f"more frames will not do (about {needed} per lamp): the lamp lines near it "
                "blend at this dispersion or are missing; use a lamp with isolated lines "
                "there, or a prism with more spread there"
            )
        fix = (
            f"take about {needed} lamp frames per lamp (set lamps.max_frames to {needed} "
            "and capture the lamp frames under a new --session)"
        )
        if capped:
            fix += (
                f", or a longer exposure: {', '.join(capped)} ran at the longest allowed "
                f"({self.max_exposure_s:g} s); raise lamps.max_s"
            )
        return said + fix

    def to_json(self) -> dict[str, Any]:
        """The record as JSON values, for the bundle's quality section."""
        last = self.batches[-1]
        return {
            "frames_per_lamp": self.frames,
            "budget": self.budget,
            "tolerance_nm": self.tolerance_nm,
            "outcome": self.outcome,
            "sigma_nm": {f"{k:g}": v for k, v in last.sigma_nm.items()},
            "exposures_s": dict(self.exposures_s),
            "batches": [b.to_json() for b in self.batches],
            "advice": self.advice(),
        }
