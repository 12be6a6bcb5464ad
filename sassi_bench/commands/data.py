"""``sassi-bench data list|clean``: what is on disk under the data root, and cleaning it.

Examples
--------
>>> from sassi_bench.commands import main
>>> main(["data", "list", "--data", "calib_data"])  # doctest: +SKIP
>>> main(["data", "clean", "--include-referenced"])  # doctest: +SKIP
"""

from __future__ import annotations

import argparse
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Any

from sassi_bench.commands.options import add_data_option
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
    _print_runs(runs)
    total = sum(e.size_bytes for e in entries)
    print(f"total {format_size(total)}; `sassi-bench data clean` shows what can be removed")
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
        "reports": args.reports,
    }
    chosen = clean_candidates(entries, runs=runs, older_than_days=args.older_than, **options)
    kept: dict[str, list[DataEntry]] = {}
    for entry in entries:
        reason = keep_reason(entry, runs=runs, **options)
        if reason in ("referenced", "interrupted", "measurement", "running"):
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


def register(subparsers: Any) -> None:
    """Add the ``data`` command group to the top-level subparsers."""
    parser = subparsers.add_parser(
        "data",
        help="list and clean sessions, staging folders and reports under the data root",
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
    p.add_argument("--reports", action="store_true", help="also report folders")
    p.add_argument(
        "--older-than", type=float, default=0.0, metavar="DAYS", help="only older entries"
    )
    p.set_defaults(func=cmd_clean)
