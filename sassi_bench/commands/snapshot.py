"""``sassi-bench snapshot take|reconstruct|export``: SASSI snapshots into cubes, or into the
files of the SASSI authors' reconstruction code.

Every command names a snapshot the way ``take`` prints it: the video's id (``--session
snap``: every frame) or one frame's (``snap-f000``); see
:mod:`sassi_bench.acquire.snapshot_ids`. ``export`` also takes any raw session with a
spectral frame tagged ``role=snapshot`` (or ``--step``/``--tag``).

Examples
--------
Not run here (it runs a command on a rig and its data)::

    from sassi_bench.commands import main
    main(["snapshot", "take", "--session", "snap", "--out", "snaps"])
    main(["snapshot", "export", "--session", "snap", "--out", "for_sassi"])
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from sassi_bench.commands.options import (
    DATA_HELP,
    add_bundle_options,
    add_data_option,
    add_rig_option,
    bundle_from_args,
    check_output_folder,
    new_session,
    program,
)
from sassi_bench.commands.snapshot_live import register_live
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["parse_tags", "register"]

#: The tags of a snapshot frame session's spectral step (``acquire.snapshots``).
SNAPSHOT_TAG = {"role": "snapshot"}


def _write(selection, bundle, procedure, out: str, envi: bool, quiet: bool) -> None:
    from tqdm.auto import tqdm

    from sassi_bench.reduce.snapshots import reconstruct_snapshots, write_frame

    video = selection.video
    frames = reconstruct_snapshots(
        video, bundle, procedure, frames=selection.frames, progress=not quiet
    )
    for session, frame in zip(selection.sessions, frames, strict=True):
        paths = write_frame(
            frame, bundle, out, session.id, session=session.id, envi=envi,
            exposure_s=video.exposures.spectral_s,
        )  # fmt: skip
        tqdm.write(
            f"  {session.id}: {int(frame.mask.sum())} open pixels, cubes "
            f"{frame.rank1.shape} ({frame.units}) -> {paths[0].parent}"
        )
    print(quick_looks(out, [session.id for session in selection.sessions]))


def quick_looks(out: str, names: list[str], shown: int = 3) -> str:
    """The line naming the frames' quick-look PNGs (the first ``shown`` of them).

    Examples
    --------
    >>> quick_looks("snaps", ["s-f000", "s-f001"])
    '  quick looks: snaps/s-f000.png, snaps/s-f001.png'
    >>> quick_looks("snaps", [f"s-f{t:03d}" for t in range(5)])
    '  quick looks: snaps/s-f000.png, snaps/s-f001.png, snaps/s-f002.png, ... (5 in snaps)'
    """
    paths = [str(Path(out) / f"{name}.png") for name in names[:shown]]
    more = f", ... ({len(names)} in {out})" if len(names) > shown else ""
    return f"  quick look{'s' if len(names) > 1 else ''}: {', '.join(paths)}{more}"


def _take(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.snapshot_ids import SnapshotSelection
    from sassi_bench.procedure import load_procedure
    from sassi_bench.reduce.snapshots import check_outputs_free
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.snapshot import check_inputs, take_snapshots

    if args.frames < 1:
        raise ProcedureError(
            step_error("snapshot take", f"--frames {args.frames}", "take 1 frame or more")
        )
    procedure = load_procedure("snapshot_validation", args.procedure)
    check_output_folder("snapshot take", args.out)
    rig = open_rig(args.rig)
    bundle = bundle_from_args(
        args,
        rig.description.name,
        step="snapshot take",
        needs=("guide_homography",),
        wants=("response",),
    )
    check_inputs(rig, bundle, args.scene, step="snapshot take")
    new_session(args, "session", f"snapshot-{args.scene}")
    check_outputs_free(args.out, [f"{args.session}-f{t:03d}" for t in range(args.frames)])
    low_light = float(procedure["snapshot"]["low_light"]) if args.low_light else 1.0
    video = take_snapshots(
        rig, bundle, procedure, scene=args.scene, frames=args.frames, low_light=low_light,
        moving=args.moving, session_id=args.session, data=args.data, progress=not args.quiet,
    )  # fmt: skip
    snapshot_id, last = args.session, len(video.frames) - 1
    print(f"Snapshots of {args.scene} on rig {rig.description.name} with bundle "
          f"{bundle.rig_name}/{bundle.version}")  # fmt: skip
    print(
        f"snapshot id: {snapshot_id} (frames {snapshot_id}-f000"
        + (f"..{snapshot_id}-f{last:03d}" if last else "")
        + f"); every `{program()} snapshot` command takes the id or one frame's"
    )
    selection = SnapshotSelection(snapshot_id, video, tuple(range(len(video.frames))), False)
    _write(selection, bundle, procedure, args.out, not args.no_envi, args.quiet)
    print(
        f"next: files for the SASSI authors' code: `{program()} snapshot export --session "
        f"{snapshot_id} --out DIR`;\n      score snapshots against a pinhole scan: "
        f"`{program()} validate snapshot --rig {args.rig} --scene {args.scene} --out REPORT`"
    )
    return 0


def _reconstruct(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.snapshot_ids import resolve_snapshot
    from sassi_bench.procedure import load_procedure
    from sassi_bench.reduce.snapshots import check_outputs_free

    procedure = load_procedure("snapshot_validation", args.procedure)
    check_output_folder("snapshot reconstruct", args.out)
    selection = resolve_snapshot(args.session, data=args.data, step="snapshot reconstruct")
    video = selection.video
    check_outputs_free(args.out, [session.id for session in selection.sessions])
    rig_name = args.rig or str(video.preview.rig.get("name", "sim"))
    bundle = bundle_from_args(
        args,
        rig_name,
        step="snapshot reconstruct",
        needs=("guide_homography",),
        wants=("response",),
    )
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
    print(f"Snapshot {selection.prefix}: {len(selection.frames)} of {len(video.frames)} frames, "
          f"with bundle {bundle.rig_name}/{bundle.version}")  # fmt: skip
    _write(selection, bundle, procedure, args.out, not args.no_envi, args.quiet)
    return 0


def _common(parser: argparse.ArgumentParser) -> None:
    add_data_option(parser)
    parser.add_argument("--out", required=True, help="folder for the cubes and quick looks")
    parser.add_argument(
        "--procedure", help="procedure YAML (default: procedures/snapshot_validation.yaml)"
    )
    parser.add_argument("--no-envi", action="store_true", help="NetCDF cubes only")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")


def parse_tags(pairs: list[str] | None) -> dict[str, Any]:
    """``["role=snapshot", "index=3"]`` -> ``{"role": "snapshot", "index": 3}`` (values
    that read as JSON are JSON, others strings).

    Examples
    --------
    >>> parse_tags(["role=snapshot", "index=3", "on=true"])
    {'role': 'snapshot', 'index': 3, 'on': True}
    """
    tags: dict[str, Any] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise ProcedureError(
                step_error("snapshot export", f"tag {pair!r} is not KEY=VALUE", "e.g. role=snap")
            )
        try:
            tags[key] = json.loads(value)
        except ValueError:
            tags[key] = value
    return tags


def _spectral_step(session, args: argparse.Namespace) -> int:
    """The spectral frame to export: ``--step``/``--tag``, else the one tagged
    ``role=snapshot`` (a snapshot frame session's spectral step)."""
    from sassi_bench.export.adaptive_cassi import select_steps

    tags = parse_tags(args.tag) if args.tag else ({} if args.step is not None else SNAPSHOT_TAG)
    spectral = select_steps(session, "spectral", step=args.step, tags=tags)
    if len(spectral) > 1:
        raise ProcedureError(
            step_error(
                "snapshot export",
                f"the tags {tags} match {len(spectral)} spectral frames of session "
                f"{session.id!r} ({spectral[:8]})",
                "pass --step N or tags that match one frame",
            )
        )
    return spectral[0]


def _guide_steps(guide_session, args: argparse.Namespace) -> list[int]:
    """``--guide-step``/``--guide-tag``, else the session's only guide frame."""
    from sassi_bench.export.adaptive_cassi import select_steps

    if args.guide_step is None and not args.guide_tag:
        captured = [
            i for i in sorted(guide_session.completed)
            if guide_session.plan.steps[i].camera == "guide"
        ]  # fmt: skip
        if len(captured) != 1:
            raise ProcedureError(
                step_error(
                    "snapshot export",
                    f"session {guide_session.id!r} has {len(captured)} guide frames "
                    f"({captured[:8]}), so which to pair is ambiguous",
                    "pass --guide-step N (repeatable) or --guide-tag KEY=VALUE",
                )
            )
        return captured
    guides: list[int] = []
    for i in args.guide_step or [None]:
        guides += select_steps(guide_session, "guide", step=i, tags=parse_tags(args.guide_tag))
    return sorted(set(guides))


def _sessions_to_export(args: argparse.Namespace) -> list[tuple[Any, Path]]:
    """(session, output folder) pairs: one per frame of a snapshot video (each into its
    own ``OUT/<frame id>``, as cassi.py reads one capture per folder), or the one frame
    or raw session named (into ``OUT``)."""
    from sassi_bench.acquire.session import Session, SessionDamagedError, SessionError
    from sassi_bench.acquire.snapshot_ids import resolve_snapshot, unknown_snapshot

    out, step = Path(args.out), "snapshot export"
    selection = resolve_snapshot(args.session, data=args.data, step=step, required=False)
    if selection is None:
        try:
            return [(Session.open(args.session, data=args.data), out)]
        except SessionDamagedError:
            raise  # it is there, damaged: say so, not that there is none
        except SessionError:
            raise unknown_snapshot(args.session, data=args.data, step=step) from None
    if selection.by_frame:
        return [(selection.sessions[0], out)]
    return [(session, out / session.id) for session in selection.sessions]


def _snapshot_export(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.session import Session, SessionDamagedError, SessionError
    from sassi_bench.export.adaptive_cassi import check_vsize, export_adaptive_cassi, select_steps

    check_output_folder("snapshot export", args.out)
    if args.vsize is not None:
        check_vsize(args.vsize)
    targets = _sessions_to_export(args)
    guide_override = None
    if args.guide_session is not None:
        try:
            guide_override = Session.open(args.guide_session, data=args.data)
        except SessionDamagedError:
            raise
        except SessionError:
            raise ProcedureError(
                step_error(
                    "snapshot export",
                    f"no session {args.guide_session!r} for --guide-session",
                    "give the id or folder of the raw session holding the guide frames, and "
                    "the same --data",
                )
            ) from None
    first = targets[0][0]
    bundle = bundle_from_args(
        args,
        args.rig or str(first.rig.get("name", "sim")),
        step="snapshot export",
        needs=("guide_homography",),
    )
    # Everything is chosen before anything is written.
    plans = []
    for session, folder in targets:
        guide_session = guide_override or session
        darks = (
            select_steps(guide_session, "guide", tags=parse_tags(args.guide_dark_tag))
            if args.guide_dark_tag
            else []
        )
        plans.append(
            (session, folder, _spectral_step(session, args), guide_session,
             _guide_steps(guide_session, args), darks)
        )  # fmt: skip
    for session, folder, spectral, guide_session, guides, darks in plans:
        done = export_adaptive_cassi(
            bundle, session, spectral, folder, guide_steps=guides, guide_session=guide_session,
            guide_dark_steps=darks, limits=args.limits, vsize=args.vsize,
        )  # fmt: skip
        h1, h2, w1, w2 = done.limits
        print(
            f"exported session {session.id!r} step {spectral} ({done.open_pixels} open SLM "
            f"pixels), guide steps {guides}"
            + (f" minus dark {darks}" if darks else "")
            + f", bundle {bundle.rig_name}/{bundle.version}, limits [{h1} {h2} {w1} {w2}]"
        )
        print(f"  {done.path}")
        choice = done.vsize_choice
        if choice is None:
            print(f"  vsize {done.vsize} (as given)")
        else:
            tried = ", ".join(
                f"{w}: {d:.1f}" for w, d in zip(choice.candidates, choice.scores_db, strict=True)
            )
            print(
                f"  vsize {done.vsize}, chosen by the authors' get_cassi_cube on this frame "
                f"(agreement with sassi-bench's spectra, dB, per window: {tried})"
            )
        for note in done.notes:
            print(f"  note: {note}")
    names = ", ".join(folder.name for _, folder, *_ in plans)
    one = len(plans) == 1
    print(
        f"next: put the calibration files of `{program()} bundle export --format sassi-mat` in "
        f"<root>/calibration/ and {'this capture folder' if one else 'these capture folders'} "
        f"({names}) in <root>/, and run cassi.py with expname set to "
        f"{'its' if one else 'each'} name"
    )
    return 0


def register(subparsers: Any) -> None:
    """Add the ``snapshot`` command group (``take``, ``reconstruct``, ``export``).

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="sassi-bench")
    >>> register(parser.add_subparsers())
    >>> args = parser.parse_args(["snapshot", "take", "--out", "snaps", "--frames", "3"])
    >>> args.func.__name__, args.frames, args.scene
    ('_take', 3, 'natural')
    >>> args = parser.parse_args(["snapshot", "export", "--session", "s", "--out", "x"])
    >>> args.func.__name__, args.format, args.limits, args.step
    ('_snapshot_export', 'sassi-mat', None, None)
    """
    parser = subparsers.add_parser(
        "snapshot",
        help="take and reconstruct SASSI snapshots, or export them for other packages",
        description="Work with SASSI snapshots (frames of a raw session and their masks).",
    )
    sub = parser.add_subparsers(dest="snapshot_command", metavar="SUBCOMMAND", required=True)
    take = sub.add_parser(
        "take",
        help="take adaptive SASSI snapshots and reconstruct them into cubes",
        description=(
            "Show the adaptive mask of the guide image (each frame's from the previous "
            "frame's guide image), capture the guide and spectral frames into raw sessions, "
            "and write rank-1 and guided cubes (NetCDF, ENVI) and a quick-look PNG per frame."
        ),
    )
    add_rig_option(take)
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
    take.set_defaults(func=_take, resume_options=(("session", "--session"),), drives_rig=True)

    rec = sub.add_parser(
        "reconstruct",
        help="reconstruct snapshots taken before into cubes",
        description=(
            "Read the raw sessions of a snapshot (`snapshot take`, or a `validate snapshot` "
            "run's <prefix>-adaptive) and write rank-1 and guided cubes and a quick look."
        ),
    )
    rec.add_argument(
        "--session", required=True,
        help="snapshot id as `snapshot take` printed it: the video (every frame) or one frame",
    )  # fmt: skip
    rec.add_argument(
        "--bundle", default="latest",
        help="bundle version of the session's rig (v0003, 3, latest) or folder (default latest)",
    )  # fmt: skip
    rec.add_argument("--rig", help="rig of --bundle (default: the session's rig)")
    _common(rec)
    rec.set_defaults(func=_reconstruct)

    p = sub.add_parser(
        "export",
        help="a spectral frame, its SLM mask and a guide frame as adaptive_cassi.mat",
        description=(
            "Write OUT/adaptive_cassi.mat (lcos_mask, cassi_img, guide_img_rec, limits) for "
            "the SASSI authors' reconstruction code, from one spectral frame of a raw "
            "session, the SLM pattern it was captured with and the guide frame(s) to pair."
        ),
    )
    p.add_argument("--format", choices=["sassi-mat"], default="sassi-mat", help="(sassi-mat)")
    p.add_argument(
        "--session", required=True,
        help="snapshot id as `snapshot take` printed it (the video: one folder per frame in "
        "--out; or one frame), or any raw session's id or folder",
    )  # fmt: skip
    which = p.add_mutually_exclusive_group()
    which.add_argument(
        "--step", type=int, help="plan step index of the spectral frame (default: role=snapshot)"
    )
    which.add_argument(
        "--tag", action="append", metavar="KEY=VALUE", help="tags of the spectral frame"
    )
    p.add_argument(
        "--guide-step", type=int, action="append", metavar="N",
        help="guide frame(s) to pair, averaged (default: the session's only guide frame, "
        "which a snapshot frame has)",
    )  # fmt: skip
    p.add_argument("--guide-tag", action="append", metavar="KEY=VALUE", help="guide frames by tag")
    p.add_argument(
        "--guide-dark-tag", action="append", metavar="KEY=VALUE",
        help="dark guide frames (light off) to subtract, by tag",
    )  # fmt: skip
    p.add_argument("--guide-session", help="session of the guide frames (default: --session)")
    p.add_argument(
        "--bundle", default="latest",
        help="bundle version of the session's rig (v0003, 3, latest) or folder (default latest)",
    )  # fmt: skip
    p.add_argument("--rig", help="rig of --bundle (default: the session's rig)")
    p.add_argument(
        "--limits", type=int, nargs=4, metavar=("H1", "H2", "W1", "W2"),
        help="SLM crop as Python slice bounds (default: the whole SLM, which cassi.py needs)",
    )  # fmt: skip
    p.add_argument(
        "--vsize", type=int, metavar="ROWS",
        help="row window for cassi.py's get_cassi_cube, odd (default: chosen by running "
        "their get_cassi_cube on the frame, which needs PyTorch: sassi-bench[sassi])",
    )  # fmt: skip
    p.add_argument("--out", required=True, help="folder to write adaptive_cassi.mat into")
    p.add_argument("--data", metavar="DIR", default=None, help=DATA_HELP)
    p.set_defaults(func=_snapshot_export)
    register_live(sub)
