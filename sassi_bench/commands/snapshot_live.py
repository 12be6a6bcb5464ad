"""``sassi-bench snapshot live|video-frame``: live snapshots into a video store, and one frame
of it out as a cube.

Examples
--------
Not run here (it runs a command on a rig and its data)::

    from sassi_bench.commands import main
    main(["snapshot", "live", "--scene", "natural", "--moving", "--frames", "20",
          "--out", "live"])
    main(["snapshot", "video-frame", "--video", "live", "--frame", "3",
          "--out", "live/f003.nc"])
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from sassi_bench.commands.options import (
    DATA_HELP,
    add_bundle_options,
    add_data_option,
    add_rig_option,
    bundle_from_args,
    check_output_folder,
    load_bundle_ref,
    program,
)

__all__ = ["register_live"]


def _live(args: argparse.Namespace) -> int:
    from sassi_bench.procedure import load_procedure
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.snapshot_live import run_live

    procedure = load_procedure("snapshot_validation", args.procedure)
    check_output_folder("snapshot live", args.out)
    rig = open_rig(args.rig)
    bundle = bundle_from_args(
        args,
        rig.description.name,
        step="snapshot live",
        needs=("guide_homography",),
        wants=("response",),
    )
    print(
        f"Live snapshots of {args.scene} on rig {rig.description.name} with bundle "
        f"{bundle.rig_name}/{bundle.version}; Ctrl-C stops and keeps every captured frame"
    )
    try:
        run = run_live(
            rig, bundle, procedure, scene=args.scene, out=args.out, frames=args.frames,
            seconds=args.seconds, moving=args.moving, queue_size=args.queue,
            progress=not args.quiet,
        )  # fmt: skip
    except KeyboardInterrupt:
        stored = Path(args.out) / "video.zarr"
        print(f"interrupted: the frames stored so far are in {stored}", file=sys.stderr)
        return 130
    print(
        f"  {run.stored} frames stored, {run.dropped} dropped of {run.captured} captured in "
        f"{run.elapsed_s:.1f} s ({run.stored / run.elapsed_s:.1f} frames/s)"
    )
    print(
        f"  capture {1e3 * run.capture_s:.0f} ms a frame ({1 / run.capture_s:.1f} frames/s; "
        f"on the virtual bench: rendering), processing {1e3 * run.process_s:.0f} ms "
        f"({1 / run.process_s:.1f} frames/s)"
    )
    print(f"  video store: {run.store}\n  quick look: {run.animation}")
    print(
        f"next: one frame as a cube: `{program()} snapshot video-frame --video {args.out} "
        f"--frame 0 --out {Path(args.out) / 'f000.nc'}`"
    )
    return 0


def _video_frame(args: argparse.Namespace) -> int:
    from sassi_bench.snapshot.video_store import export_frame, read_frame

    store = Path(args.video)
    if (store / "video.zarr").is_dir():
        store = store / "video.zarr"
    _, attrs = read_frame(store, args.frame)
    bundle = load_bundle_ref(args.bundle or attrs["bundle_version"], attrs["bundle_rig"], args.data)
    paths = export_frame(store, args.frame, bundle, args.out, envi=not args.no_envi)
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def register_live(sub: Any) -> None:
    """Add ``snapshot live`` and ``snapshot video-frame`` to the ``snapshot`` group.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="snapshot")
    >>> register_live(parser.add_subparsers())
    >>> args = parser.parse_args(["live", "--frames", "5", "--moving", "--out", "live"])
    >>> args.func.__name__, args.frames, args.moving, args.queue
    ('_live', 5, True, 2)
    """
    live = sub.add_parser(
        "live",
        help="live snapshots: capture beside reconstruction, into a video store",
        description=(
            "Capture snapshots and reconstruct them at the same time (the next frame is "
            "captured while this one is reconstructed; frames the reconstruction cannot keep "
            "up with are dropped and counted), write the rank-1 frames to OUT/video.zarr and "
            "a quick-look animation OUT/quicklook.gif. Ctrl-C keeps every captured frame."
        ),
    )
    add_rig_option(live)
    add_bundle_options(live)
    live.add_argument("--scene", default="natural", help="scene (default: natural)")
    live.add_argument(
        "--moving", action="store_true", help="move the scene between frames (virtual bench)"
    )
    end = live.add_mutually_exclusive_group(required=True)
    end.add_argument("--frames", type=int, help="stop after N captured frames")
    end.add_argument("--seconds", type=float, help="stop after S seconds")
    live.add_argument(
        "--queue", type=int, default=2, help="captured frames that may wait (default: 2)"
    )
    live.add_argument(
        "--procedure", help="procedure YAML (default: procedures/snapshot_validation.yaml)"
    )
    live.add_argument("--out", required=True, help="a new folder for the video store")
    live.add_argument("--quiet", action="store_true", help="no progress line")
    add_data_option(live)
    live.set_defaults(func=_live, drives_rig=True)

    frame = sub.add_parser(
        "video-frame",
        help="one frame of a live video store as a NetCDF (and ENVI) cube",
        description="Write frame N of a `snapshot live` video store as a rank-1 cube.",
    )
    frame.add_argument("--video", required=True, help="the live run's folder or its video.zarr")
    frame.add_argument("--frame", type=int, default=0, help="frame number (default 0; -1 last)")
    frame.add_argument("--out", required=True, help="NetCDF file to write (ENVI beside it)")
    frame.add_argument("--bundle", help="bundle folder or version (default: the store's)")
    frame.add_argument("--no-envi", action="store_true", help="NetCDF only")
    frame.add_argument("--data", metavar="DIR", default=None, help=DATA_HELP)
    frame.set_defaults(func=_video_frame)
