"""How many response frames: the stopping rule of the radiometric response and its record.

The response divides the white diffuser's deblurred mean spectrum by the source's photons
per bin; the mean states its 1-sigma from the noise alone
(:class:`~sassi_bench.spectra.deblur.MeanSpectrum`), so the response's relative 1-sigma
in a bin is the white's there, worst where the halogen is dimmest (the blue). The scan
takes every ``response.every``-th pinhole offset first; :func:`decide_response_frames`
then says whether to stop (the worst relative 1-sigma within ``response.sigma_max``, or
``response.max_frames`` pinhole frames spent) or how many to have next, by the lamp
step's rule (:func:`~sassi_bench.reduce.lamp_budget.next_frames`): each added offset opens
as many white pixels as the first ones, so the 1-sigma falls as one over the square root
of the frames. The rule is a pure function of what was measured, so a resumed session
replays the same decisions on its stored frames.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from sassi_bench.reduce.batch_record import BatchRecord
from sassi_bench.reduce.lamp_budget import frames_needed, next_frames
from sassi_bench.spectra.deblur import MeanSpectrum

__all__ = [
    "DEFAULT_MAX_FRAMES",
    "DEFAULT_TOLERANCE",
    "ResponseBatch",
    "ResponseFrameRecord",
    "decide_response_frames",
    "response_frame_settings",
    "response_sigma",
]

#: Pinhole frames the response may take when the procedure names no budget.
DEFAULT_MAX_FRAMES = 80
#: The worst relative 1-sigma of the response over the band when the procedure names none.
DEFAULT_TOLERANCE = 0.005


def response_frame_settings(response: Mapping[str, Any], first: int) -> tuple[int, int, float]:
    """The first batch, the budget (pinhole frames) and the tolerance (relative 1-sigma).

    Parameters
    ----------
    response
        The full calibration's ``response`` section.
    first
        Pinhole frames of the thinned scan (every ``every``-th offset).

    Examples
    --------
    >>> response_frame_settings({"max_frames": 60, "sigma_max": 0.004}, 20)
    (20, 60, 0.004)
    >>> response_frame_settings({}, 20)
    (20, 80, 0.005)
    """
    budget = max(first, int(response.get("max_frames") or DEFAULT_MAX_FRAMES))
    return first, budget, float(response.get("sigma_max") or DEFAULT_TOLERANCE)


def response_sigma(white: MeanSpectrum) -> float:
    """The worst relative 1-sigma of the white's mean spectrum over the band (the
    response's, which divides it by a known spectrum).

    Examples
    --------
    >>> from sassi_bench.spectra.deblur import MeanSpectrum
    >>> spectrum, std = np.array([1.0, 2.0, 4.0, 1.0]), np.array([0.5, 0.01, 0.04, 0.5])
    >>> response_sigma(MeanSpectrum(spectrum, std, 100, None, guard=1))  # guard bins left out
    0.01
    """
    g = white.guard
    std = white.std[g : white.std.size - g]
    return float(np.max(std / np.abs(white.band)))


@dataclass(frozen=True)
class ResponseBatch:
    """One decision of the response step.

    Attributes
    ----------
    frames
        Pinhole frames of the white measured when the decision was made.
    sigma
        The response's worst relative 1-sigma over the band from them.
    next_frames
        Pinhole frames to have next; None when the step stops.
    outcome
        ``"more frames"``, ``"tolerance met"`` or ``"budget spent"``.
    """

    frames: int
    sigma: float
    next_frames: int | None
    outcome: str

    def to_json(self) -> dict[str, Any]:
        """The batch as JSON values."""
        return {
            "frames": self.frames,
            "sigma_relative": self.sigma,
            "next_frames": self.next_frames,
            "outcome": self.outcome,
        }


def decide_response_frames(
    frames: int, sigma: float, tolerance: float, budget: int
) -> ResponseBatch:
    """Stop, or the pinhole frames to have next, from the response's stated 1-sigma so far.

    Parameters
    ----------
    frames
        Pinhole frames of the white measured.
    sigma
        The response's worst relative 1-sigma over the band (:func:`response_sigma`).
    tolerance
        The relative 1-sigma to reach.
    budget
        The most pinhole frames the step may take.

    Returns
    -------
    ResponseBatch

    Examples
    --------
    >>> decide_response_frames(20, 0.0042, 0.005, 80).outcome
    'tolerance met'
    >>> decide_response_frames(20, 0.0042, 0.003, 80).next_frames  # 20 * (4.2 / 3)**2
    40
    """
    return ResponseBatch(frames, float(sigma), *next_frames(frames, sigma, tolerance, budget))


@dataclass(frozen=True)
class ResponseFrameRecord(BatchRecord):
    """What the response step took and why (its frames, outcome and batches as
    :class:`~sassi_bench.reduce.batch_record.BatchRecord` reads them).

    Attributes
    ----------
    batches
        Every decision, in order (the last one stopped).
    tolerance, budget
        The tolerance (relative 1-sigma) and the budget (pinhole frames) it worked to.
    every
        The first batch's thinning: every n-th pinhole offset.
    """

    sigma_attribute = "sigma"

    batches: tuple[ResponseBatch, ...]
    tolerance: float
    budget: int
    every: int

    @property
    def sigma(self) -> float:
        """The response's worst relative 1-sigma at the end."""
        return self.batches[-1].sigma

    def advice(self) -> str | None:
        """What would meet the tolerance when the budget was spent (None otherwise).

        Examples
        --------
        >>> last = ResponseBatch(80, 0.006, None, "budget spent")
        >>> print(ResponseFrameRecord((last,), 0.005, 80, 25).advice())
        response at +-0.60 % after 80 pinhole frames of the white: take about 116 \
(set response.max_frames to 116 and run the response under a new --session), or light \
the diffuser brighter in the blue
        """
        if self.outcome != "budget spent":
            return None
        needed = frames_needed(self.frames, self.sigma, self.tolerance)
        return (
            f"response at +-{100 * self.sigma:.2f} % after {self.frames} pinhole frames of "
            f"the white: take about {needed} (set response.max_frames to {needed} and run "
            "the response under a new --session), or light the diffuser brighter in the blue"
        )

    def note(self) -> str:
        """One line for the report: what was taken and why.

        Examples
        --------
        >>> first = ResponseBatch(20, 0.0042, 40, "more frames")
        >>> last = ResponseBatch(40, 0.0029, None, "tolerance met")
        >>> print(ResponseFrameRecord((first, last), 0.003, 80, 25).note())
        response frames: 40 pinhole frames of the white (20, then 40): the response at \
+-0.29 % (1-sigma, worst bin; tolerance 0.30 %): tolerance met
        """
        return self.with_advice(
            f"response frames: {self.frames} pinhole frames of the white ({self.taken()}): "
            f"the response at +-{100 * self.sigma:.2f} % (1-sigma, worst bin; tolerance "
            f"{100 * self.tolerance:.2f} %): {self.outcome}"
        )

    def to_json(self) -> dict[str, Any]:
        """The record as JSON values, for the bundle's quality section."""
        return {
            "frames": self.frames,
            "every": self.every,
            "budget": self.budget,
            "tolerance_relative": self.tolerance,
            "outcome": self.outcome,
            "sigma_relative": self.sigma,
            "batches": [b.to_json() for b in self.batches],
            "advice": self.advice(),
        }
