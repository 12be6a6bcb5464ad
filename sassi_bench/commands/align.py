"""``sassi-bench align``: the readings a person aligns a bench by, round after round.

A sparse pinhole pattern on the SLM, one spectral frame per laser each round, and per
round one line per reading with its value, target and advice: spot widths and the
wavelength of best focus against the rig's described blur, the streak roll against the
camera rows, the SLM image's footprint on the camera, each frame's exposure
(:mod:`sassi_bench.reduce.alignment`). The rig's lock is held while it runs; Ctrl-C
frees it.
"""

from __future__ import annotations

import argparse

from sassi_bench.commands.options import (
    add_data_option,
    add_rig_option,
    add_simulate_option,
    program,
)

__all__ = ["register"]


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive whole number")
    return value


def _align(args: argparse.Namespace) -> int:
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.align import run_alignment

    simulate = " --simulate" if args.simulate else ""
    if not args.no_view:
        print(
            "align: the readings follow as text; to watch both cameras live beside them: "
            f"{program()} live --rig {args.rig}{simulate}"
        )
    rig = open_rig(args.rig, simulate=args.simulate)

    def show(result) -> None:
        print(
            f"round {result.index + 1}/{args.frames} (capture {result.capture_s:.1f} s, "
            f"readings {result.processing_s:.2f} s)"
        )
        for reading in result.readings:
            print(reading.line(), flush=True)

    done = run_alignment(rig, rounds=args.frames, lights=args.lights, data=args.data, on_round=show)
    aligned = all(r.ok for r in done[-1].readings)
    if aligned:
        print(f"aligned. next: {program()} calibrate spectral --rig {args.rig}{simulate}")
    else:
        print(
            "turn what the TURN lines say, then read again: "
            f"{program()} align --rig {args.rig}{simulate} --no-view"
        )
    return 0 if aligned else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``align`` command to the top-level parser."""
    align = sub.add_parser(
        "align",
        help="alignment readings: focus, streak roll, footprint, exposure",
        description="Show sparse pinholes on the SLM and read the spectral camera under "
        "each laser: spot widths and best focus against the rig's described blur, the "
        "streak roll against the camera rows, the SLM image's footprint on the camera "
        "and each frame's exposure, one line per reading with its target and advice. "
        "Exit status 1 while something needs turning.",
    )
    add_rig_option(align)
    add_simulate_option(align)
    add_data_option(align)
    align.add_argument(
        "--frames", type=_positive, default=1, help="rounds of frames to read (default 1)"
    )
    align.add_argument(
        "--no-view", action="store_true", help="print the readings as text (no live view)"
    )
    align.add_argument(
        "--lights", nargs="+", metavar="LIGHT", help="lights to read under (default: every laser)"
    )
    align.set_defaults(func=_align, drives_rig=True)
