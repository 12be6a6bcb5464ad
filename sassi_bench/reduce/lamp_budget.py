"""How many lamp frames: the stopping rule of the lamp step and the record of what it took.

The lamp frames anchor every laser's wavelength; how well depends on photons (faint lines,
a noisy camera) and on the rig's dispersion (lines that blend). The lamp step therefore
measures in batches: after each, the anchored fit states every laser's 1-sigma from the
frames taken so far, and :func:`decide_lamp_frames` says whether to stop (every laser
within ``tolerances.laser_wavelength_sigma_nm``, ``lamps.max_frames`` spent, or a floor
that frames do not lower keeping the tolerance out of reach) or how many frames per lamp
to have next. A photon-limited uncertainty falls as one over the square root of the
frames, and lines that blend add a floor, so the next batch aims at the frames photons
and floor need, within the budget. The rule is a pure function of what was measured, so
a resumed session replays the same decisions on the same frames and captures none twice.
:func:`next_frames` is that rule alone, shared with the blur, response and health-check
steps.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from sassi_bench.reduce.batch_record import BatchRecord, fell_with_photons, photon_sigma

__all__ = [
    "DEFAULT_MAX_FRAMES",
    "LampBatch",
    "LampFrameRecord",
    "decide_lamp_frames",
    "frames_needed",
    "frames_to_meet",
    "lamp_frame_settings",
    "next_frames",
    "photon_floor",
    "stalled",
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
        ``"more frames"``, ``"tolerance met"``, ``"budget spent"`` or ``"out of reach"``.
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
    frames: int,
    sigma_nm: Mapping[float, float],
    tolerance_nm: float,
    budget: int,
    earlier: Sequence[LampBatch] = (),
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
    earlier
        The earlier batches, whose 1-sigmas of the laser now worst tell photons from a
        floor (:func:`next_frames`).

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
    >>> first = decide_lamp_frames(4, {520.0: 0.05, 670.0: 0.533}, 0.5, 16)
    >>> second = decide_lamp_frames(5, {520.0: 0.045, 670.0: 0.531}, 0.5, 16, [first])
    >>> second.next_frames
    6
    >>> decide_lamp_frames(6, {670.0: 0.529}, 0.5, 16, [first, second]).outcome
    'out of reach'
    """
    sigma = {float(k): float(v) for k, v in sigma_nm.items()}
    label = max(sigma, key=sigma.__getitem__, default=None)
    worst = sigma[label] if label is not None else 0.0
    before = _history(earlier, label)
    return LampBatch(frames, sigma, *next_frames(frames, worst, tolerance_nm, budget, before))


def _history(batches: Sequence[LampBatch], label: float | None) -> list[tuple[int, float]]:
    """(frames, 1-sigma) of one laser over the batches that measured it."""
    return [(b.frames, b.sigma_nm[label]) for b in batches if label in b.sigma_nm]


def next_frames(
    frames: int,
    sigma: float,
    tolerance: float,
    budget: int,
    earlier: Sequence[tuple[int, float]] = (),
) -> tuple[int | None, str]:
    """The stopping rule of a step that measures until confident: the frames to have next
    (None: stop) and why, from the worst 1-sigma reached with ``frames`` frames.

    A photon-limited 1-sigma falls as one over the square root of the frames: the next
    batch aims at the frames that would meet the tolerance (at least one more), within
    the budget. From the second batch on the last two are read as photons plus a floor
    that frames do not change (``sigma**2 = a / frames + floor**2``,
    :func:`photon_floor`), and the next batch aims at what both need. A fitted 1-sigma
    scatters from batch to batch, so one pair of batches does not stop the step: when
    the last two pairs each put the floor at the tolerance or above and neither fell by
    :data:`~sassi_bench.reduce.batch_record.PHOTON_SHARE` of what photons give, the step
    stops (``"out of reach"``: more frames would not meet it).

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
    earlier
        The earlier batches' frames and 1-sigma of the same quantity, oldest first.

    Returns
    -------
    tuple
        ``(next frames or None, outcome)``, the outcome ``"more frames"``,
        ``"tolerance met"``, ``"budget spent"`` or ``"out of reach"``.

    Examples
    --------
    >>> next_frames(2, 0.08, 0.05, 8)
    (6, 'more frames')
    >>> next_frames(8, 0.08, 0.05, 8)
    (None, 'budget spent')
    >>> next_frames(6, 0.529, 0.5, 16, earlier=[(4, 0.533), (5, 0.531)])  # lines that blend
    (None, 'out of reach')
    >>> next_frames(8, 0.55, 0.5, 16, earlier=[(4, 0.62)])  # photons alone would say 10
    (16, 'more frames')
    """
    if frames < 1 or budget < 1:
        raise ValueError(f"frames ({frames}) and budget ({budget}) must be positive")
    if sigma <= tolerance:
        return None, "tolerance met"
    if frames >= budget:
        return None, "budget spent"
    points = [*[(int(n), float(s)) for n, s in earlier if n < frames][-2:], (frames, sigma)]
    wanted = frames_to_meet(points[-1], tolerance, points[-2] if len(points) > 1 else None)
    if wanted is None:
        if len(points) == 3 and stalled(points, tolerance):
            return None, "out of reach"
        wanted = frames_needed(frames, sigma, tolerance)
    return min(budget, max(wanted, frames + 1)), "more frames"


def stalled(points: Sequence[tuple[int, float]], tolerance: float) -> bool:
    """Whether every consecutive pair of ``points`` (frames, 1-sigma) puts the floor at
    the tolerance or above and fell by less than photons give.

    Examples
    --------
    >>> stalled([(4, 0.533), (5, 0.531), (6, 0.529)], 0.5)
    True
    >>> stalled([(2, 0.0552), (3, 0.0549), (4, 0.0512)], 0.05)  # a scattered 1-sigma
    False
    """
    return all(
        photon_floor(a, b)[1] >= tolerance and not fell_with_photons(a, b)
        for a, b in itertools.pairwise(points)
    )


def photon_floor(earlier: tuple[int, float], later: tuple[int, float]) -> tuple[float, float]:
    """Split two batches' 1-sigmas into photons and a floor: ``sigma**2 = a / frames +
    floor**2``, returning ``(sqrt(a), floor)`` (the 1-sigma of one frame's photons, and
    what no number of frames takes away), neither below zero.

    Examples
    --------
    >>> [round(x, 3) for x in photon_floor((4, 0.6), (16, 0.3))]  # photons alone
    [1.2, 0.0]
    >>> [round(x, 3) for x in photon_floor((4, 0.533), (5, 0.531))]
    [0.206, 0.523]
    """
    (n1, s1), (n2, s2) = earlier, later
    a = max((s1**2 - s2**2) / (1.0 / n1 - 1.0 / n2), 0.0)
    return math.sqrt(a), math.sqrt(max(s2**2 - a / n2, 0.0))


def frames_needed(frames: int, sigma: float, tolerance: float) -> int:
    """The frames at which a photon-limited 1-sigma, ``sigma`` after ``frames``, meets the
    tolerance.

    Examples
    --------
    >>> frames_needed(16, 0.6, 0.5)
    24
    """
    return math.ceil(frames * (sigma / tolerance) ** 2 - 1e-9)


def frames_to_meet(
    later: tuple[int, float], tolerance: float, earlier: tuple[int, float] | None = None
) -> int | None:
    """The frames at which a 1-sigma meets the tolerance: photon-limited from one batch
    (:func:`frames_needed`), photons and floor from two (:func:`photon_floor`); None when
    the floor alone is at the tolerance or above.

    Examples
    --------
    >>> frames_to_meet((16, 0.6), 0.5), frames_to_meet((8, 0.55), 0.5, (4, 0.62))
    (24, 23)
    >>> frames_to_meet((5, 0.531), 0.5, (4, 0.533)) is None
    True
    """
    if earlier is None or earlier[0] >= later[0]:
        return frames_needed(later[0], later[1], tolerance)
    photons, floor = photon_floor(earlier, later)
    if floor >= tolerance:
        return None
    return math.ceil(photons**2 / (tolerance**2 - floor**2) - 1e-9)


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
        """What would meet the tolerance when the step stopped short of it (None
        otherwise).

        Examples
        --------
        >>> first = LampBatch(4, {670.0: 0.533}, 5, "more frames")
        >>> last = LampBatch(5, {670.0: 0.531}, None, "out of reach")
        >>> print(LampFrameRecord((first, last), 0.5, 16, {"lamp:Ne": 0.4}, 10.0).advice())
        laser 670 nm at +-0.53 nm after 5 lamp frames: more frames will not do (its 1-sigma \
went from 0.533 to 0.531 nm where photons alone give 0.477): the lamp lines near it blend \
at this dispersion or are missing; use a lamp with isolated lines there, or a prism with \
more spread there
        >>> last = LampBatch(16, {670.0: 0.6}, None, "budget spent")
        >>> print(LampFrameRecord((last,), 0.5, 16, {"lamp:Ne": 0.4}, 10.0).advice())
        laser 670 nm at +-0.60 nm after 16 lamp frames: take about 24 lamp frames per lamp \
(set lamps.max_frames to 24 and capture the lamp frames under a new --session)
        """
        if self.outcome not in ("budget spent", "out of reach"):
            return None
        label = max(self.short_of, key=self.short_of.__getitem__)
        later = (self.frames, self.short_of[label])
        history = _history(self.batches[:-1], label)
        earlier = history[-1] if history else None
        needed = frames_to_meet(later, self.tolerance_nm, earlier)
        lasers = ", ".join(f"laser {k:g} nm at +-{v:.2f} nm" for k, v in self.short_of.items())
        said = f"{lasers} after {self.frames} lamp frames: "
        capped = [k for k, t in self.exposures_s.items() if t >= 0.999 * self.max_exposure_s]
        if needed is None or needed > HOPELESS_FACTOR * self.budget:
            if needed is not None:
                why = f"about {needed} per lamp"
            else:  # a floor at the tolerance (frames_to_meet gives None only with earlier)
                why = f"a floor of +-{photon_floor(earlier, later)[1]:.3f} nm"
            if earlier is not None and not fell_with_photons(earlier, later):
                why = (
                    f"its 1-sigma went from {earlier[1]:.3f} to {later[1]:.3f} nm where "
                    f"photons alone give {photon_sigma(earlier, later[0]):.3f}"
                )
            return said + (
                f"more frames will not do ({why}): the lamp lines near it blend at this "
                "dispersion or are missing; use a lamp with isolated lines there, or a "
                "prism with more spread there"
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
