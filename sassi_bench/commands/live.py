"""``sassi-bench live``: both cameras live in a browser page, with the alignment readings.

Serves the live view (:mod:`sassi_bench.workflows.live_view`) on the loopback interface
behind a random token and prints the address to open; the page shows the spectral and
guide cameras' newest frames with their clipped pixels in colour, histograms, the rates,
dropped frames and latency, and the alignment readings every few seconds. The rig's lock
is held while it runs; Ctrl-C or SIGTERM stops it and frees the rig (nothing is stored).
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


def _live(args: argparse.Namespace) -> int:
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.live_view import serve_live

    rig = open_rig(args.rig, simulate=args.simulate)
    simulate = " --simulate" if args.simulate else ""

    def ready(server) -> None:
        print(f"live view of {args.rig}: open {server.url}", flush=True)
        print(
            "(this machine only; the token in the address is the key). "
            "Ctrl-C stops it and frees the rig; "
            f"then: {program()} align --rig {args.rig}{simulate} --no-view",
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


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``live`` command to the top-level parser."""
    live = sub.add_parser(
        "live",
        help="live view of both cameras with the alignment readings, in a browser page",
        description="Show the alignment pattern on the SLM and serve a page (this machine "
        "only, behind a token) with the spectral and guide cameras live: clipped pixels "
        "in colour, histograms, frames per second, dropped frames and latency, and every "
        "few seconds the alignment readings (spot widths, best focus, streak roll, the "
        "SLM image's footprint). Ctrl-C stops it.",
    )
    add_rig_option(live)
    add_simulate_option(live)
    add_data_option(live)
    live.add_argument(
        "--port", type=_port, default=0, help="port to serve on (default 0: a free one)"
    )
    live.add_argument(
        "--lights",
        nargs="+",
        metavar="LIGHT",
        help="lights of the readings rounds (default: every laser); the live frames are "
        "taken under the one nearest the prism's reference wavelength. With lights the "
        "operator switches, name one",
    )
    live.add_argument(
        "--max-fps", type=_rate, default=10.0, help="most live frames a second (default 10)"
    )
    live.add_argument(
        "--exposure",
        type=_seconds,
        metavar="SECONDS",
        help="exposure of the live frames (default: auto-exposure's)",
    )
    live.set_defaults(func=_live, drives_rig=True)
