"""``sassi-bench align`` (also ``live``): the live view with the alignment readings, or,
with ``--no-view``, the readings as text round after round.

Both show a sparse pinhole pattern on the SLM and read the spectral camera under each
laser: spot widths and the wavelength of best focus against the rig's described blur,
the streak roll against the camera rows, the SLM image's footprint on the camera and
each frame's exposure (:mod:`sassi_bench.reduce.alignment`), each reading with its
target and advice. The view (:mod:`sassi_bench.workflows.live_view`) serves both
cameras live beside those readings on the loopback interface behind a random token and
prints the address to open; ``--no-view`` prints one line per reading each round. The
rig's lock is held while either runs; Ctrl-C or SIGTERM stops it and frees the rig
(nothing is stored).
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

#: The options only the live view reads, with their defaults.
VIEW_DEFAULTS = {"port": 0, "max_fps": 10.0, "exposure": None}


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive whole number")
    return value


def _port(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"{text!r} is not a port (0-65535; 0: a free one)")
    return value


def _rate(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = 0.0
    if not 0 < value <= 100:
        raise argparse.ArgumentTypeError(f"{text!r} is not a rate between 0 and 100 a second")
    return value


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = 0.0
    if not 0 < value <= 60:
        raise argparse.ArgumentTypeError(f"{text!r} is not an exposure between 0 and 60 s")
    return value


def _check_mode(args: argparse.Namespace) -> None:
    """Refuse the options of one form given to the other, before the rig is opened."""
    from sassi_bench.errors import ConfigError, step_error

    if args.no_view:
        given = [
            "--" + name.replace("_", "-")
            for name, default in VIEW_DEFAULTS.items()
            if getattr(args, name) != default
        ]
        if given:
            raise ConfigError(
                step_error(
                    "align --no-view",
                    f"{', '.join(given)} set the live view, which --no-view does not serve",
                    "drop them, or drop --no-view to watch the cameras live",
                )
            )
    elif args.frames is not None:
        raise ConfigError(
            step_error(
                "align",
                "--frames counts the rounds --no-view prints; the live view reads "
                "round after round until Ctrl-C",
                "add --no-view, or drop --frames",
            )
        )


def _readings_as_text(args: argparse.Namespace, simulate: str) -> int:
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.align import run_alignment

    rounds = args.frames or 1
    rig = open_rig(args.rig, simulate=args.simulate)

    def show(result) -> None:
        print(
            f"round {result.index + 1}/{rounds} (capture {result.capture_s:.1f} s, "
            f"readings {result.processing_s:.2f} s)"
        )
        for reading in result.readings:
            print(reading.line(), flush=True)

    done = run_alignment(rig, rounds=rounds, lights=args.lights, data=args.data, on_round=show)
    aligned = all(r.ok for r in done[-1].readings)
    if aligned:
        print(f"aligned. next: {program()} calibrate spectral --rig {args.rig}{simulate}")
    else:
        print(
            "turn what the TURN lines say, then read again: "
            f"{program()} align --rig {args.rig}{simulate} --no-view"
        )
    return 0 if aligned else 1


def _live_view(args: argparse.Namespace, simulate: str) -> int:
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.live_view import serve_live

    rig = open_rig(args.rig, simulate=args.simulate)

    def ready(server) -> None:
        print(f"live view of {args.rig}: open {server.url}", flush=True)
        print(
            "(this machine only; the token in the address is the key). "
            "Ctrl-C stops it and frees the rig; once every reading is ok: "
            f"{program()} calibrate spectral --rig {args.rig}{simulate}",
            flush=True,
        )

    try:
        serve_live(
            rig,
            port=args.port,
            lights=args.lights,
            data=args.data,
            max_fps=args.max_fps,
            live_exposure_s=args.exposure,
            on_ready=ready,
        )
    finally:
        rig.close()
    return 0


def _align(args: argparse.Namespace) -> int:
    _check_mode(args)
    simulate = " --simulate" if args.simulate else ""
    if args.no_view:
        return _readings_as_text(args, simulate)
    return _live_view(args, simulate)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``align`` command (and its other name, ``live``) to the top-level parser.

    Examples
    --------
    >>> parser = argparse.ArgumentParser()
    >>> register(parser.add_subparsers())
    >>> args = parser.parse_args(["live", "--rig", "sim", "--max-fps", "5"])
    >>> args.func.__name__, args.no_view, args.max_fps
    ('_align', False, 5.0)
    """
    align = sub.add_parser(
        "align",
        aliases=["live"],
        help="the live view with the alignment readings (focus, streak roll, footprint, "
        "exposure); --no-view: the readings as text",
        description="Show sparse pinholes on the SLM and read the spectral camera under "
        "each laser: spot widths and best focus against the rig's described blur, the "
        "streak roll against the camera rows, the SLM image's footprint on the camera "
        "and each frame's exposure, each with its target and which way to turn. Serves "
        "a page (this machine only, behind a token) with the spectral and guide cameras "
        "live beside the readings: clipped pixels in colour, histograms, frames per "
        "second, dropped frames and latency; Ctrl-C stops it. With --no-view, prints one "
        "line per reading each round instead, exit status 1 while something needs "
        "turning. 'live' is another name for this command.",
    )
    add_rig_option(align)
    add_simulate_option(align)
    add_data_option(align)
    align.add_argument(
        "--no-view", action="store_true", help="print the readings as text (no live view)"
    )
    align.add_argument(
        "--frames",
        type=_positive,
        help="with --no-view: rounds of readings to print (default 1)",
    )
    align.add_argument(
        "--lights",
        nargs="+",
        metavar="LIGHT",
        help="lights the readings are taken under (default: every laser); the live "
        "frames are taken under the one nearest the prism's reference wavelength. With "
        "lights the operator switches, name one for the live view",
    )
    align.add_argument(
        "--port",
        type=_port,
        default=VIEW_DEFAULTS["port"],
        help="live view: port to serve on (default 0: a free one)",
    )
    align.add_argument(
        "--max-fps",
        type=_rate,
        default=VIEW_DEFAULTS["max_fps"],
        help="live view: most frames a second (default 10)",
    )
    align.add_argument(
        "--exposure",
        type=_seconds,
        metavar="SECONDS",
        default=VIEW_DEFAULTS["exposure"],
        help="live view: exposure of the live frames (default: auto-exposure's)",
    )
    align.set_defaults(func=_align, drives_rig=True)
