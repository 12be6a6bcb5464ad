"""What a step that measures until confident took: the reading its records share.

The lamp, blur, response and health-check steps each decide after every batch of frames
whether to stop (:func:`~sassi_bench.reduce.lamp_budget.next_frames`) and keep the
decisions as a record of batches. :class:`BatchRecord` reads such a record the same way
for all of them (the frames taken, the outcome, the batches in a line, whether the
1-sigma fell as photon noise does); each step's record adds its own wording and JSON.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, ClassVar

__all__ = ["PHOTON_SHARE", "BatchRecord", "fell_with_photons", "photon_sigma"]

#: A batch whose 1-sigma fell by less than this share of what photons alone would give
#: is limited by something frames do not change (the model's form, the lines).
PHOTON_SHARE = 0.5


def photon_sigma(earlier: tuple[int, float], frames: int) -> float:
    """What photons alone make of a 1-sigma ``earlier`` (frames, 1-sigma) with ``frames``.

    Examples
    --------
    >>> photon_sigma((4, 0.6), 16)
    0.3
    """
    return earlier[1] * math.sqrt(earlier[0] / frames)


def fell_with_photons(earlier: tuple[int, float], later: tuple[int, float]) -> bool:
    """Whether a 1-sigma fell from ``earlier`` to ``later`` (frames, 1-sigma) by at least
    :data:`PHOTON_SHARE` of what photons alone give.

    Examples
    --------
    >>> fell_with_photons((4, 0.6), (16, 0.32)), fell_with_photons((4, 0.533), (5, 0.531))
    (True, False)
    """
    first, last = earlier[1], later[1]
    return first - last >= PHOTON_SHARE * (first - photon_sigma(earlier, later[0]))


class BatchRecord:
    """The shared reading of a record of batches (a base of the steps' frozen dataclasses).

    A subclass is a dataclass with a ``batches`` field, each batch having ``frames`` and
    ``outcome`` and the 1-sigma in the attribute ``sigma_attribute`` names, and defines
    :meth:`advice`.

    Examples
    --------
    >>> from dataclasses import dataclass
    >>> @dataclass(frozen=True)
    ... class Batch:
    ...     frames: int
    ...     sigma_px: float
    ...     outcome: str
    >>> @dataclass(frozen=True)
    ... class Record(BatchRecord):
    ...     batches: tuple
    ...     def advice(self):
    ...         return None
    >>> record = Record((Batch(2, 0.08, "more frames"), Batch(6, 0.075, "budget spent")))
    >>> record.frames, record.outcome, record.taken(), record.photon_limited()
    (6, 'budget spent', '2, then 6', False)
    """

    batches: Sequence[Any]
    #: The name of the batches' 1-sigma attribute.
    sigma_attribute: ClassVar[str] = "sigma_px"

    @property
    def frames(self) -> int:
        """Frames taken (the last batch's)."""
        return self.batches[-1].frames

    @property
    def outcome(self) -> str:
        """``"tolerance met"``, ``"budget spent"`` or ``"out of reach"`` (a floor frames do
        not lower keeps the tolerance out of reach:
        :func:`~sassi_bench.reduce.lamp_budget.next_frames`)."""
        return self.batches[-1].outcome

    def taken(self) -> str:
        """The frames after each batch, in order (``"2, then 6"``)."""
        return ", then ".join(str(b.frames) for b in self.batches)

    def photon_limited(self) -> bool | None:
        """Whether the 1-sigma fell with the frames as photon noise does (None after one
        batch): one that hardly falls is set by the model or the lines, not by photons."""
        if len(self.batches) < 2:
            return None
        first, last = self.batches[0], self.batches[-1]
        return fell_with_photons(
            (first.frames, getattr(first, self.sigma_attribute)),
            (last.frames, getattr(last, self.sigma_attribute)),
        )

    def advice(self) -> str | None:
        """What would meet the tolerance when the budget was spent (None otherwise)."""
        raise NotImplementedError

    def with_advice(self, line: str) -> str:
        """``line``, followed by the advice when there is some."""
        advice = self.advice()
        return line if advice is None else f"{line}; {advice}"
