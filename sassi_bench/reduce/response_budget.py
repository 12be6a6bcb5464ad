"""How many response frames: the stopping rule of the radiometric response and its record.

The response divides the white diffuser's deblurred mean spectrum by the source's photons
per bin; the mean states its covariance between bins from the noise alone
(:class:`~sassi_bench.spectra.deblur.MeanSpectrum`), so the response's relative error is
the white's. What that error does to colour is the step's figure: the mean over the 24
ColorChecker patches of the CIEDE2000 1-sigma it causes
(:mod:`~sassi_bench.reduce.response_colour`). The worst bin's relative 1-sigma (the deep
blue, where the halogen is dimmest) is recorded too, and is a tolerance only when the
procedure sets ``response.sigma_max``.

The scan takes every ``response.every``-th pinhole offset first;
:func:`decide_response_frames` then says whether to stop (the colour 1-sigma within
``response.de00_sigma_max``, and the relative one within ``sigma_max`` when set, or
``response.max_frames`` pinhole frames spent) or how many to have next, by the lamp
step's rule (:func:`~sassi_bench.reduce.lamp_budget.next_frames`): each added offset opens
as many white pixels as the first ones, so both 1-sigma fall as one over the square root
of the frames. The rule is a pure function of what was measured, so a resumed session
replays the same decisions on its stored frames.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sassi_bench.reduce.batch_record import BatchRecord
from sassi_bench.reduce.lamp_budget import frames_needed, next_frames
from sassi_bench.reduce.response_colour import (
    ColourChart,
    relative_covariance,
    response_colour_error,
)
from sassi_bench.spectra.deblur import MeanSpectrum

__all__ = [
    "DEFAULT_DE00_TOLERANCE",
    "DEFAULT_MAX_FRAMES",
    "ResponseBatch",
    "ResponseFrameRecord",
    "ResponseSettings",
    "decide_response_frames",
    "response_de00_sigma",
    "response_frame_settings",
    "response_sigma",
    "shortfall",
]

#: Pinhole frames the response may take when the procedure names no budget.
DEFAULT_MAX_FRAMES = 80
#: The response's colour 1-sigma (mean CIEDE2000 over the ColorChecker's patches) when the
#: procedure names none: a tenth of the rig family's mean CIEDE2000 target of 0.5, so
#: in quadrature it adds under 1 % to it (``docs/notes/2026-11-30-response-colour.md``).
DEFAULT_DE00_TOLERANCE = 0.05


@dataclass(frozen=True)
class ResponseSettings:
    """The response step's first batch, budget and tolerances.

    Attributes
    ----------
    first, budget
        Pinhole frames of the thinned scan, and the most the step may take.
    de00_max
        The colour 1-sigma to reach (mean CIEDE2000 over the patches).
    sigma_max
        The worst bin's relative 1-sigma to reach; None: recorded, not a tolerance.
    """

    first: int
    budget: int
    de00_max: float
    sigma_max: float | None = None


def response_frame_settings(response: Mapping[str, Any], first: int) -> ResponseSettings:
    """The first batch, the budget (pinhole frames) and the tolerances.

    Parameters
    ----------
    response
        The full calibration's ``response`` section.
    first
        Pinhole frames of the thinned scan (every ``every``-th offset).

    Examples
    --------
    >>> response_frame_settings({"max_frames": 60, "de00_sigma_max": 0.1}, 20)
    ResponseSettings(first=20, budget=60, de00_max=0.1, sigma_max=None)
    >>> response_frame_settings({"sigma_max": 0.004}, 20)
    ResponseSettings(first=20, budget=80, de00_max=0.05, sigma_max=0.004)
    """
    budget = max(first, int(response.get("max_frames") or DEFAULT_MAX_FRAMES))
    de00 = float(response.get("de00_sigma_max") or DEFAULT_DE00_TOLERANCE)
    sigma = response.get("sigma_max")
    return ResponseSettings(first, budget, de00, None if sigma is None else float(sigma))


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


def response_de00_sigma(white: MeanSpectrum, chart: ColourChart) -> float:
    """The colour 1-sigma of the response from the white's noise: the mean over the
    chart's patches of each one's CIEDE2000 1-sigma
    (:func:`~sassi_bench.reduce.response_colour.response_colour_error`).

    Examples
    --------
    >>> from sassi_bench.spectra.deblur import MeanSpectrum
    >>> to_xyz = np.tile([0.95, 1.0, 1.09], (30, 1)) / 30
    >>> chart = ColourChart(np.full((1, 30), 0.5), to_xyz, np.array([0.3127, 0.3290]))
    >>> white = MeanSpectrum(np.ones(32), np.full(32, 0.001), 100, None, guard=1)
    >>> round(response_de00_sigma(white, chart), 3)  # 0.1 % per bin: a grey's lightness
    0.004
    """
    return response_colour_error(relative_covariance(white), chart).mean


@dataclass(frozen=True)
class ResponseBatch:
    """One decision of the response step.

    Attributes
    ----------
    frames
        Pinhole frames of the white measured when the decision was made.
    sigma
        The response's worst relative 1-sigma over the band from them.
    de00_sigma
        The colour 1-sigma it causes (mean CIEDE2000 over the patches).
    next_frames
        Pinhole frames to have next; None when the step stops.
    outcome
        ``"more frames"``, ``"tolerance met"``, ``"budget spent"`` or ``"out of reach"``.
    """

    frames: int
    sigma: float
    de00_sigma: float
    next_frames: int | None
    outcome: str

    def to_json(self) -> dict[str, Any]:
        """The batch as JSON values."""
        return {
            "frames": self.frames,
            "sigma_relative": self.sigma,
            "de00_sigma": self.de00_sigma,
            "next_frames": self.next_frames,
            "outcome": self.outcome,
        }


def shortfall(de00_sigma: float, sigma: float, settings: ResponseSettings) -> float:
    """How far the response is from its tolerances: the largest ratio of a 1-sigma to its
    tolerance (the relative one's only when ``sigma_max`` is set); both fall alike with
    the frames, so the ratio's square is the frames' factor still wanted.

    Examples
    --------
    >>> shortfall(0.06, 0.009, ResponseSettings(20, 80, 0.05))
    1.2
    >>> round(shortfall(0.06, 0.009, ResponseSettings(20, 80, 0.05, sigma_max=0.005)), 6)
    1.8
    """
    ratio = de00_sigma / settings.de00_max
    if settings.sigma_max is not None:
        ratio = max(ratio, sigma / settings.sigma_max)
    return float(ratio)


def decide_response_frames(
    frames: int,
    sigma: float,
    de00_sigma: float,
    settings: ResponseSettings,
    earlier: Sequence[ResponseBatch] = (),
) -> ResponseBatch:
    """Stop, or the pinhole frames to have next, from the response's stated 1-sigma so far.

    Parameters
    ----------
    frames
        Pinhole frames of the white measured.
    sigma
        The response's worst relative 1-sigma over the band (:func:`response_sigma`).
    de00_sigma
        The colour 1-sigma it causes (:func:`response_de00_sigma`).
    settings
        The budget and the tolerances (:func:`response_frame_settings`).
    earlier
        The earlier batches, which tell photons from a floor
        (:func:`~sassi_bench.reduce.lamp_budget.next_frames`).

    Returns
    -------
    ResponseBatch

    Examples
    --------
    >>> settings = ResponseSettings(20, 80, 0.05)
    >>> decide_response_frames(20, 0.0099, 0.042, settings).outcome  # the worst bin is free
    'tolerance met'
    >>> decide_response_frames(20, 0.0042, 0.07, settings).next_frames  # 20 * (7 / 5)**2
    40
    """
    ratio = shortfall(de00_sigma, sigma, settings)
    before = [(b.frames, shortfall(b.de00_sigma, b.sigma, settings)) for b in earlier]
    return ResponseBatch(
        frames,
        float(sigma),
        float(de00_sigma),
        *next_frames(frames, ratio, 1.0, settings.budget, before),
    )


@dataclass(frozen=True)
class ResponseFrameRecord(BatchRecord):
    """What the response step took and why (its frames, outcome and batches as
    :class:`~sassi_bench.reduce.batch_record.BatchRecord` reads them).

    Attributes
    ----------
    batches
        Every decision, in order (the last one stopped).
    settings
        The budget (pinhole frames) and the tolerances it worked to.
    every
        The first batch's thinning: every n-th pinhole offset.
    """

    sigma_attribute = "de00_sigma"

    batches: tuple[ResponseBatch, ...]
    settings: ResponseSettings
    every: int

    @property
    def sigma(self) -> float:
        """The response's worst relative 1-sigma at the end."""
        return self.batches[-1].sigma

    @property
    def de00_sigma(self) -> float:
        """The response's colour 1-sigma at the end."""
        return self.batches[-1].de00_sigma

    def advice(self) -> str | None:
        """What would meet the tolerance when the step stopped short of it (None
        otherwise).

        Examples
        --------
        >>> last = ResponseBatch(80, 0.012, 0.06, None, "budget spent")
        >>> print(ResponseFrameRecord((last,), ResponseSettings(20, 80, 0.05), 25).advice())
        response's colour 1-sigma 0.060 CIEDE2000 after 80 pinhole frames of the white: take \
about 116 (set response.max_frames to 116 and run the response under a new --session), \
or light the diffuser brighter
        """
        if self.outcome not in ("budget spent", "out of reach"):
            return None
        said = (
            f"response's colour 1-sigma {self.de00_sigma:.3f} CIEDE2000 after {self.frames} "
            "pinhole frames of the white: "
        )
        if self.outcome == "out of reach":
            return said + (
                "more frames will not do (its 1-sigma hardly fell with them): the white's "
                "frames scatter more than their photons; let the lamp and the camera warm "
                "up, or hold the lamp's supply steady"
            )
        ratio = shortfall(self.de00_sigma, self.sigma, self.settings)
        needed = frames_needed(self.frames, ratio, 1.0)
        return said + (
            f"take about {needed} (set response.max_frames to {needed} and run the response "
            "under a new --session), or light the diffuser brighter"
        )

    def note(self) -> str:
        """One line for the report: what was taken and why.

        Examples
        --------
        >>> first = ResponseBatch(20, 0.0092, 0.07, 40, "more frames")
        >>> last = ResponseBatch(40, 0.0065, 0.049, None, "tolerance met")
        >>> print(ResponseFrameRecord((first, last), ResponseSettings(20, 80, 0.05), 25).note())
        response frames: 40 pinhole frames of the white (20, then 40): the colour error \
from its noise 0.049 CIEDE2000 (1-sigma, mean over the ColorChecker; tolerance 0.050), \
the worst bin at +-0.65 %: tolerance met
        """
        relative = f"the worst bin at +-{100 * self.sigma:.2f} %"
        if self.settings.sigma_max is not None:
            relative += f" (tolerance {100 * self.settings.sigma_max:.2f} %)"
        return self.with_advice(
            f"response frames: {self.frames} pinhole frames of the white ({self.taken()}): "
            f"the colour error from its noise {self.de00_sigma:.3f} CIEDE2000 (1-sigma, mean over "
            f"the ColorChecker; tolerance {self.settings.de00_max:.3f}), {relative}: "
            f"{self.outcome}"
        )

    def to_json(self) -> dict[str, Any]:
        """The record as JSON values, for the bundle's quality section."""
        return {
            "frames": self.frames,
            "every": self.every,
            "budget": self.settings.budget,
            "tolerance_de00": self.settings.de00_max,
            "tolerance_relative": self.settings.sigma_max,
            "outcome": self.outcome,
            "de00_sigma": self.de00_sigma,
            "sigma_relative": self.sigma,
            "batches": [b.to_json() for b in self.batches],
            "advice": self.advice(),
        }
