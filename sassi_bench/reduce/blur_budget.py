"""How many blur pinhole frames: the stopping rule of the blur step and its record.

The field blur (:func:`~sassi_bench.calibrate.blur.fit_field_covariance`) states the
1-sigma of the spot widths it predicts, the worst over the field and the band
(``BlurFit.width_sigma_px``). The sweep takes ``blur.frames`` pinhole frames per laser;
the blur step then fits, and :func:`decide_blur_frames` says whether to stop (the stated
1-sigma within ``tolerances.blur_width_sigma_px``, or ``blur.max_frames`` spent) or how
many frames per laser to have next, by the lamp step's rule
(:func:`~sassi_bench.reduce.lamp_budget.next_frames`). The rule is a pure function of
what was measured, so a resumed session replays the same decisions on the stored frames.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from sassi_bench.reduce.batch_record import BatchRecord
from sassi_bench.reduce.lamp_budget import frames_needed, next_frames

__all__ = [
    "DEFAULT_MAX_FRAMES",
    "BlurBatch",
    "BlurFrameRecord",
    "LampFieldFrameRecord",
    "blur_frame_settings",
    "decide_blur_frames",
]

#: Pinhole frames per laser the blur step may take when the procedure names no budget.
DEFAULT_MAX_FRAMES = 8
#: The stated 1-sigma (camera px) when the procedure names none: half the 0.1 px a lab
#: expects of the blur anywhere on the field.
DEFAULT_TOLERANCE_PX = 0.05


def blur_frame_settings(procedure: Mapping[str, Any]) -> tuple[int, int, float]:
    """The sweep's pinhole frames per laser, the budget and the tolerance (px).

    Examples
    --------
    >>> blur_frame_settings({"blur": {"frames": 2}, "tolerances": {}})
    (2, 8, 0.05)
    >>> blur_frame_settings({"blur": {"frames": 4, "max_frames": 2}, "tolerances": {}})
    (4, 4, 0.05)
    """
    blur = procedure.get("blur") or {}
    first = int(blur.get("frames", 2))
    budget = max(first, int(blur.get("max_frames") or DEFAULT_MAX_FRAMES))
    tolerances = procedure.get("tolerances") or {}
    return first, budget, float(tolerances.get("blur_width_sigma_px", DEFAULT_TOLERANCE_PX))


@dataclass(frozen=True)
class BlurBatch:
    """One decision of the blur step.

    Attributes
    ----------
    frames
        Pinhole frames per laser measured when the decision was made.
    sigma_px
        The field blur's stated worst 1-sigma of its widths from those frames (camera px).
    next_frames
        Frames per laser to have next; None when the step stops.
    outcome
        ``"more frames"``, ``"tolerance met"``, ``"budget spent"`` or ``"out of reach"``.
    """

    frames: int
    sigma_px: float
    next_frames: int | None
    outcome: str

    def to_json(self) -> dict[str, Any]:
        """The batch as JSON values."""
        return {
            "frames": self.frames,
            "sigma_px": self.sigma_px,
            "next_frames": self.next_frames,
            "outcome": self.outcome,
        }


def decide_blur_frames(
    frames: int,
    sigma_px: float,
    tolerance_px: float,
    budget: int,
    earlier: Sequence[BlurBatch] = (),
) -> BlurBatch:
    """Stop, or the pinhole frames per laser to have next, from the stated 1-sigma so far.

    Parameters
    ----------
    frames
        Pinhole frames per laser measured.
    sigma_px
        The field blur's stated worst 1-sigma of its widths (camera px).
    tolerance_px
        The 1-sigma to reach.
    budget
        The most pinhole frames per laser the step may take.
    earlier
        The earlier batches, which tell photons from a floor
        (:func:`~sassi_bench.reduce.lamp_budget.next_frames`).

    Returns
    -------
    BlurBatch

    Examples
    --------
    >>> decide_blur_frames(2, 0.04, 0.05, 8).outcome
    'tolerance met'
    >>> decide_blur_frames(2, 0.08, 0.05, 8).next_frames  # 2 * (0.08 / 0.05)**2
    6
    >>> decide_blur_frames(8, 0.08, 0.05, 8).outcome
    'budget spent'
    """
    before = [(b.frames, b.sigma_px) for b in earlier]
    return BlurBatch(
        frames, float(sigma_px), *next_frames(frames, sigma_px, tolerance_px, budget, before)
    )


@dataclass(frozen=True)
class BlurFrameRecord(BatchRecord):
    """What the blur step took and why (its frames, outcome and batches as
    :class:`~sassi_bench.reduce.batch_record.BatchRecord` reads them).

    Attributes
    ----------
    batches
        Every decision, in order (the last one stopped).
    tolerance_px, budget
        The tolerance and the budget it worked to.
    """

    batches: tuple[BlurBatch, ...]
    tolerance_px: float
    budget: int

    #: The step's name, what its frames count (and their key in JSON) and the setting of
    #: its budget.
    step: ClassVar[str] = "blur frames"
    frames_of: ClassVar[str] = "pinhole frames per laser"
    json_frames: ClassVar[str] = "frames_per_laser"
    budget_setting: ClassVar[str] = "blur.max_frames"

    @property
    def sigma_px(self) -> float:
        """The stated worst 1-sigma at the end (camera px)."""
        return self.batches[-1].sigma_px

    def advice(self) -> str | None:
        """What would meet the tolerance when the step stopped short of it (None
        otherwise).

        Examples
        --------
        >>> last = BlurBatch(8, 0.06, None, "budget spent")
        >>> print(BlurFrameRecord((last,), 0.05, 8).advice())
        field blur widths at +-0.060 px after 8 pinhole frames per laser: take about 12 \
(set blur.max_frames to 12 and capture under a new --session)
        """
        if self.outcome not in ("budget spent", "out of reach"):
            return None
        said = f"field blur widths at +-{self.sigma_px:.3f} px after {self.frames} "
        said += f"{self.frames_of}: "
        if self.photon_limited() is False:
            return said + (
                "more frames will not do (the uncertainty hardly fell with them): the field "
                "series cannot follow the spots; raise blur.field_degree, or give the blur "
                "more lines (blur.extra_lasers_nm)"
            )
        needed = frames_needed(self.frames, self.sigma_px, self.tolerance_px)
        return said + (
            f"take about {needed} (set {self.budget_setting} to {needed} and capture under "
            "a new --session)"
        )

    def note(self) -> str:
        """One line for the report: what was taken and why.

        Examples
        --------
        >>> first = BlurBatch(2, 0.07, 4, "more frames")
        >>> last = BlurBatch(4, 0.045, None, "tolerance met")
        >>> print(BlurFrameRecord((first, last), 0.05, 8).note())
        blur frames: 4 pinhole frames per laser (2, then 4): the field blur's widths at \
+-0.045 px (1-sigma, worst over the field; tolerance 0.05 px): tolerance met
        """
        return self.with_advice(
            f"{self.step}: {self.frames} {self.frames_of} ({self.taken()}): the field "
            f"blur's widths at +-{self.sigma_px:.3f} px (1-sigma, worst over the field; "
            f"tolerance {self.tolerance_px:g} px): {self.outcome}"
        )

    def to_json(self) -> dict[str, Any]:
        """The record as JSON values, for the bundle's quality section."""
        return {
            self.json_frames: self.frames,
            "budget": self.budget,
            "tolerance_px": self.tolerance_px,
            "outcome": self.outcome,
            "sigma_px": self.sigma_px,
            "batches": [b.to_json() for b in self.batches],
            "advice": self.advice(),
        }


@dataclass(frozen=True)
class LampFieldFrameRecord(BlurFrameRecord):
    """What the lamp field step took and why: the field blur's lamp lines past the
    lasers' band (its frames per offset of the lamp pinhole grid, in batches until the
    field blur's stated widths meet ``tolerances.blur_width_sigma_px``, within the lamp
    budget ``lamps.max_frames``).

    Examples
    --------
    >>> first = BlurBatch(4, 0.078, 10, "more frames")
    >>> last = BlurBatch(10, 0.049, None, "tolerance met")
    >>> print(LampFieldFrameRecord((first, last), 0.05, 16).note())
    lamp field frames: 10 lamp frames per offset (4, then 10): the field blur's widths at \
+-0.049 px (1-sigma, worst over the field; tolerance 0.05 px): tolerance met
    """

    step: ClassVar[str] = "lamp field frames"
    frames_of: ClassVar[str] = "lamp frames per offset"
    json_frames: ClassVar[str] = "frames_per_offset"
    budget_setting: ClassVar[str] = "lamps.max_frames"
