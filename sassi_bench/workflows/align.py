"""Alignment on the bench: a sparse pinhole pattern on the SLM, frames under a broadband
light and the lasers, and the readings a person aligns by (:mod:`sassi_bench.reduce.alignment`).

Each round shows the pattern, captures one spectral frame per light at the exposure found
for it once at the start, and computes the readings; ``sassi-bench align`` prints them,
round after round. The rig's lock is held for the whole run (Ctrl-C frees it).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.trigger_gate import armed
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.alignment import Reading, alignment_pattern, alignment_readings
from sassi_bench.rig.rig import Rig, check_light
from sassi_bench.workflows.rig_lock import drives_rig

__all__ = ["AlignmentRound", "alignment_lights", "run_alignment"]


@dataclass
class AlignmentRound:
    """One round: its readings and how long capture and processing took."""

    index: int
    readings: list[Reading]
    capture_s: float
    processing_s: float
    frames: dict[str, NDArray[np.generic]] = field(default_factory=dict, repr=False)


def alignment_lights(rig: Rig, asked: Sequence[str] | None = None) -> list[str]:
    """The lights a round captures: those asked for (checked against the rig), else
    every laser of the rig (focus at each line, the roll between the outer two).

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> alignment_lights(open_rig("sim"))
    ['laser:450', 'laser:520', 'laser:532', 'laser:635', 'laser:670']
    """
    available = rig.light.available
    if asked:
        return [check_light(name, available, step="align") for name in asked]
    return [name for name in available if name.startswith("laser:")]


@drives_rig("align")
def run_alignment(
    rig: Rig,
    *,
    rounds: int = 1,
    lights: Sequence[str] | None = None,
    data: str | os.PathLike[str] | None = None,
    on_round: Callable[[AlignmentRound], None] | None = None,
    max_exposure_s: float = 2.0,
) -> list[AlignmentRound]:
    """Show the alignment pattern and read the bench ``rounds`` times.

    Parameters
    ----------
    rig
        The rig.
    rounds
        How many rounds of frames (one frame per light each).
    lights
        The lights to capture under (default: :func:`alignment_lights`).
    data
        The data root (for the rig's lock).
    on_round
        Called with every round as soon as it is read (printing, a live view).
    max_exposure_s
        The longest exposure auto-exposure may choose.

    Returns
    -------
    list of AlignmentRound

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        from sassi_bench import open_rig
        done = run_alignment(open_rig("sim"), lights=["laser:532"])
        done[0].readings[0].name
        # 'spot width 532 nm'
    """
    if rounds < 1:
        raise ProcedureError(
            step_error("align", f"--frames {rounds} is not a positive number", "give 1 or more")
        )
    desc = rig.description
    pattern = alignment_pattern(desc)
    names = alignment_lights(rig, lights)
    shown = render_pattern(pattern, rig.slm.shape)
    rig.set_scene("white")
    camera = rig.spectral_camera
    exposure = {
        name: auto_exposure(rig, name, pattern, max_s=max_exposure_s, target_fraction=0.6)
        for name in names
    }
    done: list[AlignmentRound] = []
    with armed(rig):
        for index in range(rounds):
            start = time.monotonic()
            rig.slm.show(shown)
            frames = {}
            for name in names:
                rig.light.select(name)
                camera.set_exposure(exposure[name])
                frames[name] = camera.capture().data
            captured = time.monotonic()
            readings = alignment_readings(desc, pattern, frames, camera.bit_depth)
            result = AlignmentRound(
                index, readings, captured - start, time.monotonic() - captured, frames
            )
            done.append(result)
            if on_round is not None:
                on_round(result)
    return done
