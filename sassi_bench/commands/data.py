"""``sassi-bench data list|clean|verify``: what is on disk under the data root, cleaning
it, and checking that the sessions are whole.

Examples
--------
Not run here (it runs a command on a rig and its data)::

    from sassi_bench.commands import main
    main(["data", "list", "--data", "calib_data"])
    main(["data", "clean", "--include-referenced"])
    main(["data", "verify", "scan-20261122T101500Z"])
"""

from __future__ import annotations

import argparse
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from sassi_bench.commands.options import add_data_option, program
from sassi_bench.errors import ProcedureError, step_error

if TYPE_CHECKING:
    from sassi_bench.storage.inventory import DataEntry
    from sassi_bench.storage.runs import RunRecord

__all__ = ["register"]


def _age(entry: DataEntry, now: datetime) -> str:
    hours = (now - entry.modified).total_seconds() / 3600
    return f"{hours:.0f} h" if hours < 48 else f"{hours / 24:.0f} d"


def _state(entry: DataEntry, runs: list[RunRecord]) -> str:
    """A session's frames, marked when incomplete or part of an interrupted run."""
    if entry.kind == "leftover":
        return "leftover of an interrupted write"
    if entry.damaged:
        return "DAMAGED (below)"
    if entry.frames is None:
        return "-"
    done, planned = entry.frames
    owner = next((r for r in runs if r.owns(entry.path.name)), None)
    if owner is not None and owner.state == "running":
        return f"capturing {done}/{planned}"
    if entry.incomplete:
        return f"INCOMPLETE {done}/{planned} (resumes)"
    return f"{done} frames" + (" (run interrupted)" if owner is not None else "")


def _table(entries: list[DataEntry], runs: list[RunRecord]) -> str:
    from sassi_bench._shared.tables import text_table
    from sassi_bench.storage.inventory import format_size

    now = datetime.now(UTC)
    rows = [
        [
            e.kind, e.name, format_size(e.size_bytes), _age(e, now), _state(e, runs),
            ", ".join(e.used_by) or "-",
        ]
        for e in entries
    ]  # fmt: skip
    return text_table(["KIND", "NAME", "SIZE", "AGE", "STATE", "USED BY"], rows)


def _print_runs(runs: list[RunRecord]) -> None:
    """The runs that did not finish, with the command that resumes each."""
    for run in runs:
        if run.state == "running":
            print(f"run {run.run}: running (pid {run.pid} on {run.host}, since {run.started})")
        else:
            how = f" by {run.note}" if run.note else " (its process is gone)"
            print(f"run {run.run}: interrupted{how}, started {run.started}. Resume with:")
            print(f"  {run.command}")


def _data_option(args: argparse.Namespace) -> str:
    """`` --data DIR`` when the command was given one (for the commands it prints)."""
    import shlex

    return f" --data {shlex.quote(args.data)}" if args.data else ""


def _print_damaged(entries: list[DataEntry], args: argparse.Namespace) -> None:
    """The damaged sessions, what is wrong with each, and what to do."""
    damaged = [e for e in entries if e.damaged]
    if not damaged:
        return
    print(
        f"{len(damaged)} damaged session(s), kept (`data clean` removes them only with "
        "--include-damaged):"
    )
    for entry in damaged:
        print(f"  {entry.name}: {entry.damage}")
    names = " ".join(e.name for e in damaged) if len(damaged) <= 3 else "NAME"
    print(
        f"  each frame checked, and what is left of each: "
        f"{program()} data verify {names}{_data_option(args)}"
    )


def cmd_list(args: argparse.Namespace) -> int:
    """``data list``: every session, staging folder, bundle and report, with sizes, and
    the runs that were interrupted with the command that resumes each."""
    from sassi_bench.paths import data_root
    from sassi_bench.storage.inventory import format_size, inventory
    from sassi_bench.storage.runs import read_runs

    root = data_root(args.data)
    entries, runs = inventory(root), read_runs(root)
    if not entries and not runs:
        print(f"nothing under {root}")
        return 0
    print(f"data root {root.resolve()}")
    print(_table(entries, runs))
    _print_damaged(entries, args)
    _print_runs(runs)
    total = sum(e.size_bytes for e in entries)
    print(
        f"total {format_size(total)}; `{program()} data clean{_data_option(args)}` shows what "
        "can be removed"
    )
    return 0


def cmd_clean(args: argparse.Namespace) -> int:
    """``data clean``: a dry run unless ``--yes``; never a published bundle, and no
    measurement, bundle input or interrupted run's session unless asked."""
    from sassi_bench.paths import data_root
    from sassi_bench.storage.clean import KEEP_REASONS, clean_candidates, keep_reason, remove
    from sassi_bench.storage.inventory import format_size, inventory
    from sassi_bench.storage.runs import read_runs

    if not args.older_than >= 0:
        raise ProcedureError(
            step_error(
                "data clean",
                f"--older-than {args.older_than:g} is not a number of days >= 0",
                "give the age in days, e.g. --older-than 7",
            )
        )
    root = data_root(args.data)
    entries, runs = inventory(root), read_runs(root)
    options = {
        "include_referenced": args.include_referenced,
        "include_measurements": args.include_measurements,
        "include_interrupted": args.include_interrupted,
        "include_damaged": args.include_damaged,
        "reports": args.reports,
    }
    chosen = clean_candidates(entries, runs=runs, older_than_days=args.older_than, **options)
    kept: dict[str, list[DataEntry]] = {}
    for entry in entries:
        reason = keep_reason(entry, runs=runs, **options)
        if reason in ("referenced", "interrupted", "measurement", "running", "damaged"):
            kept.setdefault(reason, []).append(entry)
    for reason, found in kept.items():
        what, option = KEEP_REASONS[reason]
        size = format_size(sum(e.size_bytes for e in found))
        also = f" ({option} removes them too)" if option else ""
        print(f"keeping {len(found)} folder(s) ({size}): {what}{also}")
    if not chosen:
        print(f"nothing to clean under {root}")
        return 0
    print(_table(chosen, runs))
    size = format_size(sum(e.size_bytes for e in chosen))
    if not args.yes:
        print(f"dry run: {len(chosen)} folder(s), {size} would be removed; add --yes to remove")
        return 0
    freed = remove(chosen, root)
    print(f"removed {len(chosen)} folder(s), {format_size(freed)}")
    return 0


def _sessions_named(names: list[str], entries: list[DataEntry], root) -> list[DataEntry]:
    """The session entries ``names`` name: as ``data list`` shows them, by id, or by folder."""
    from pathlib import Path

    sessions = [e for e in entries if e.kind == "session"]
    if not names:
        return sessions
    chosen = []
    for name in names:
        folder = Path(name).resolve() if Path(name).is_dir() else None
        found = [
            e
            for e in sessions
            if name in (e.name, e.path.name) or (folder is not None and e.path.resolve() == folder)
        ]
        if not found:
            raise ProcedureError(
                step_error(
                    "data verify",
                    f"no session {name!r} under {root}",
                    f"give a name `{program()} data list` shows (sessions/ID, "
                    "staging/RUN/sessions/ID), a session id or its folder, and the same --data",
                )
            )
        chosen.extend(e for e in found if e not in chosen)
    return chosen


def cmd_verify(args: argparse.Namespace) -> int:
    """``data verify``: read every frame of the sessions named (default: all) against what
    their event logs recorded; name what is missing or damaged, and with ``--retake`` set
    those frames aside so that the capture, run again, takes them again."""
    from tqdm.auto import tqdm

    from sassi_bench.paths import data_root
    from sassi_bench.storage.integrity import open_quietly, verify_session
    from sassi_bench.storage.inventory import inventory

    root = data_root(args.data)
    chosen = _sessions_named(args.sessions, inventory(root), root)
    if not chosen:
        print(f"no sessions under {root}")
        return 0
    total = sum(e.frames[0] if e.frames else 0 for e in chosen)
    damaged: list[str] = []
    bar = tqdm(total=total, desc="frames", unit="frame", disable=args.quiet)
    with bar:
        for entry in chosen:
            result = verify_session(entry.path, on_frame=lambda _: bar.update())
            if result.whole:
                bar.write(f"ok       {entry.name}: {result.checked} frames")
                continue
            damaged.append(entry.name)
            if result.unreadable is not None:
                bar.write(f"DAMAGED  {entry.name}: {result.unreadable}")
                bar.write(f"         what is left: {result.salvage}")
                bar.write(f"         its {result.checked} logged frames checked against the log:")
            else:
                bar.write(f"DAMAGED  {entry.name}: {len(result.damages)} of "
                          f"{result.checked} frames")  # fmt: skip
            for line in result.damages[:20]:
                bar.write(f"           {line}")
            if len(result.damages) > 20:
                bar.write(f"           ... and {len(result.damages) - 20} more")
            if args.retake and result.found:
                kept = open_quietly(entry.path).set_aside(result.found)
                bar.write(
                    f"         set aside {len(kept)} frame(s) (kept in {entry.name}/damaged/): "
                    "the capture that made the session takes them again when run again with "
                    "the same session id"
                )
    if damaged:
        print(f"{len(damaged)} of {len(chosen)} session(s) damaged; nothing was changed"
              + (" but the frames set aside" if args.retake else ""))  # fmt: skip
        if not args.retake:
            names = " ".join(damaged) if len(damaged) <= 3 else "NAME"
            print(
                "restore the files named from a backup, or set the damaged frames aside so "
                f"the capture takes them again: {program()} data verify {names} --retake"
                f"{_data_option(args)}"
            )
        return 1
    print(f"{len(chosen)} session(s), {total} frames: every frame is as it was stored")
    return 0


def register(subparsers: Any) -> None:
    """Add the ``data`` command group to the top-level subparsers."""
    parser = subparsers.add_parser(
        "data",
        help="list, check and clean sessions, staging folders and reports under the data root",
        description="What the workbench keeps under the data root, and cleaning it up.",
    )
    sub = parser.add_subparsers(dest="data_command", metavar="SUBCOMMAND", required=True)
    common = argparse.ArgumentParser(add_help=False)
    add_data_option(common)
    p = sub.add_parser(
        "list", parents=[common], help="sessions, staging folders, bundles, reports; sizes"
    )
    p.set_defaults(func=cmd_list)
    p = sub.add_parser(
        "clean",
        parents=[common],
        help="remove calibration by-products no published bundle needs (dry run)",
        description=(
            "Remove staged intermediate bundles and calibration captures no published "
            "bundle uses. Published bundles are never removed; bundle inputs, scans and "
            "snapshots, and sessions of interrupted runs only with their --include option."
        ),
    )
    p.add_argument("--yes", action="store_true", help="really remove (default: dry run)")
    p.add_argument(
        "--include-referenced",
        action="store_true",
        help="also sessions that published bundles use as inputs (their raw evidence)",
    )
    p.add_argument(
        "--include-measurements",
        action="store_true",
        help="also scans and snapshots taken by commands (measurements in their own right)",
    )
    p.add_argument(
        "--include-interrupted",
        action="store_true",
        help="also sessions of interrupted runs and incomplete sessions (they resume)",
    )
    p.add_argument(
        "--include-damaged",
        action="store_true",
        help="also damaged sessions (unreadable header or log, frames missing or damaged)",
    )
    p.add_argument("--reports", action="store_true", help="also report folders")
    p.add_argument(
        "--older-than", type=float, default=0.0, metavar="DAYS", help="only older entries"
    )
    p.set_defaults(func=cmd_clean)
    p = sub.add_parser(
        "verify",
        parents=[common],
        help="read every frame of sessions against what was recorded when it was stored",
        description=(
            "Read every stored frame of the sessions named (default: every session) and "
            "check it against the checksum and SHA-256 its event log recorded; name each "
            "frame missing or damaged, and what is left of a session whose header or log "
            "does not read. Exit status 1 when anything is damaged. Only reads, unless "
            "--retake."
        ),
    )
    p.add_argument(
        "sessions",
        nargs="*",
        metavar="SESSION",
        help="a name as `data list` shows it, a session id, or a session folder",
    )
    p.add_argument(
        "--retake",
        action="store_true",
        help="set damaged frames aside (kept in the session's damaged/ folder) so that the "
        "capture, run again with the same session id, takes them again",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_verify)
