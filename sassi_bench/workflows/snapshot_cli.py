"""``sassi-bench snapshot take`` and ``sassi-bench snapshot reconstruct``."""

from __future__ import annotations

import argparse
from pathlib import Path

from sassi_bench.bundle.cli import add_bundle_options
from sassi_bench.cli import check_output_folder, new_session
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["register"]


def _write(video, bundle, procedure, out: str, envi: bool, quiet: bool) -> None:
    from tqdm.auto import tqdm

    from sassi_bench.workflows.snapshot import reconstruct_snapshots, write_frame

    frames = reconstruct_snapshots(video, bundle, procedure, progress=not quiet)
    for session, frame in zip(video.frames, frames, strict=True):
        paths = write_frame(frame, bundle, out, session.id, session=session.id, envi=envi)
        tqdm.write(
            f"  {session.id}: {int(frame.mask.sum())} open pixels, cubes "
            f"{frame.rank1.shape} ({frame.units}) -> {paths[0].parent}"
        )
    print(f"  quick look: {Path(out) / (video.frames[0].id + '.png')}")


def _take(args: argparse.Namespace) -> int:
    from sassi_bench.bundle.cli import bundle_from_args
    from sassi_bench.rig import open_rig
    from sassi_bench.validate.snapshot import check_inputs
    from sassi_bench.workflows.procedure import load_procedure
    from sassi_bench.workflows.snapshot import check_outputs_free, take_snapshots

    if args.frames < 1:
        raise ProcedureError(
            step_error("snapshot take", f"--frames {args.frames}", "take 1 frame or more")
        )
    procedure = load_procedure("snapshot_validation", args.procedure)
    check_output_folder("snapshot take", args.out)
    rig = open_rig(args.rig)
    bundle = bundle_from_args(args, rig.description.name)
    check_inputs(rig, bundle, args.scene)
    new_session(args, "session", f"snapshot-{args.scene}")
    check_outputs_free(args.out, [f"{args.session}-f{t:03d}" for t in range(args.frames)])
    low_light = float(procedure["snapshot"]["low_light"]) if args.low_light else 1.0
    video = take_snapshots(
        rig, bundle, procedure, scene=args.scene, frames=args.frames, low_light=low_light,
        moving=args.moving, session_id=args.session, data=args.data, progress=not args.quiet,
    )  # fmt: skip
    print(f"Snapshots of {args.scene} on rig {rig.description.name} with bundle "
          f"{bundle.rig_name}/{bundle.version}: sessions {args.session}-*")  # fmt: skip
    _write(video, bundle, procedure, args.out, not args.no_envi, args.quiet)
    print(
        f"next: score snapshots against a pinhole scan with `sassi-bench validate snapshot "
        f"--rig {args.rig} --scene {args.scene} --out REPORT`"
    )
    return 0


def _reconstruct(args: argparse.Namespace) -> int:
    from sassi_bench.bundle import load
    from sassi_bench.bundle.layout import resolve_bundle_ref
    from sassi_bench.workflows.procedure import load_procedure
    from sassi_bench.workflows.snapshot import check_outputs_free, open_snapshots

    procedure = load_procedure("snapshot_validation", args.procedure)
    check_output_folder("snapshot reconstruct", args.out)
    video = open_snapshots(args.session, data=args.data)
    check_outputs_free(args.out, [session.id for session in video.frames])
    rig_name = args.rig or str(video.preview.rig.get("name", "sim"))
    bundle = load(resolve_bundle_ref(args.bundle, rig=rig_name, data=args.data))
    if bundle.guide_to_slm is None or tuple(bundle.slm_shape) != video.mask(0).shape:
        raise ProcedureError(
            step_error(
                "snapshot reconstruct",
                f"bundle {bundle.rig_name}/{bundle.version} cannot reconstruct these frames "
                f"(SLM {bundle.slm_shape} against masks {video.mask(0).shape}; guide "
                f"homography {'present' if bundle.guide_to_slm is not None else 'missing'})",
                "pass the bundle of the rig that took them, with a guide homography (--bundle)",
            )
        )
    print(f"Snapshot {args.session} ({len(video.frames)} frames) with bundle "
          f"{bundle.rig_name}/{bundle.version}")  # fmt: skip
    _write(video, bundle, procedure, args.out, not args.no_envi, args.quiet)
    return 0


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--data", help="data root for sessions and bundles")
    parser.add_argument("--out", required=True, help="folder for the cubes and quick looks")
    parser.add_argument(
        "--procedure", help="procedure YAML (default: procedures/snapshot_validation.yaml)"
    )
    parser.add_argument("--no-envi", action="store_true", help="NetCDF cubes only")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``take`` and ``reconstruct`` to the ``snapshot`` command group.

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="sassi-bench")
    >>> register(parser.add_subparsers())
    >>> args = parser.parse_args(["take", "--out", "snaps", "--frames", "3"])
    >>> args.func.__name__, args.frames, args.scene
    ('_take', 3, 'natural')
    """
    take = sub.add_parser(
        "take",
        help="take adaptive SASSI snapshots and reconstruct them into cubes",
        description=(
            "Show the adaptive mask of the guide image (each frame's from the previous "
            "frame's guide image), capture the guide and spectral frames into raw sessions, "
            "and write rank-1 and guided cubes (NetCDF, ENVI) and a quick-look PNG per frame."
        ),
    )
    take.add_argument("--rig", default="sim", help="rig name or YAML path (default: sim)")
    add_bundle_options(take)
    take.add_argument("--scene", default="natural", help="scene (default: natural)")
    take.add_argument("--frames", type=int, default=1, help="snapshot frames (default: 1)")
    take.add_argument(
        "--moving", action="store_true", help="move the scene between frames (virtual bench)"
    )
    take.add_argument(
        "--low-light", action="store_true", help="the procedure's photon-starved exposure"
    )
    take.add_argument("--session", help="session id prefix; an existing one resumes")
    _common(take)
    take.set_defaults(func=_take, resume_options=(("session", "--session"),))

    rec = sub.add_parser(
        "reconstruct",
        help="reconstruct snapshots taken before into cubes",
        description=(
            "Read the raw sessions of a snapshot (`snapshot take`, or a `validate snapshot` "
            "run's <prefix>-adaptive) and write rank-1 and guided cubes and a quick look."
        ),
    )
    rec.add_argument("--session", required=True, help="session id prefix of the snapshot")
    rec.add_argument(
        "--bundle", default="latest",
        help="bundle version of the session's rig (v0003, 3, latest) or folder (default latest)",
    )  # fmt: skip
    rec.add_argument("--rig", help="rig of --bundle (default: the session's rig)")
    _common(rec)
    rec.set_defaults(func=_reconstruct)
