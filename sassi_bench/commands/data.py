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

__all__ = ["register"]


def _age(entry: DataEntry, now: datetime) -> str:
    hours = (now - entry.modified).total_seconds() / 3600
    return f"{hours:.0f} h" if hours < 48 else f"{hours / 24:.0f} d"


def _table(entries: list[DataEntry]) -> str:
    from sassi_bench._shared.tables import text_table
    from sassi_bench.storage.inventory import format_size

    now = datetime.now(UTC)
    rows = [
        [e.kind, e.name, format_size(e.size_bytes), _age(e, now), ", ".join(e.used_by) or "-"]
        for e in entries
    ]
    return text_table(["KIND", "NAME", "SIZE", "AGE", "USED BY"], rows)


def cmd_list(args: argparse.Namespace) -> int:
    """``data list``: every session, staging folder, bundle and report, with sizes."""
    from sassi_bench.paths import data_root
    from sassi_bench.storage.inventory import format_size, inventory

    root = data_root(args.data)
    entries = inventory(root)
    if not entries:
        print(f"nothing under {root}")
        return 0
    print(f"data root {root.resolve()}")
    print(_table(entries))
    total = sum(e.size_bytes for e in entries)
    print(f"total {format_size(total)}; `sassi-bench data clean` shows what can be removed")
    return 0


def cmd_clean(args: argparse.Namespace) -> int:
    """``data clean``: a dry run unless ``--yes``; never a published bundle."""
    from sassi_bench.paths import data_root
    from sassi_bench.storage.clean import clean_candidates, remove
    from sassi_bench.storage.inventory import format_size, inventory

    if not args.older_than >= 0:
        raise ProcedureError(
            step_error(
                "data clean",
                f"--older-than {args.older_than:g} is not a number of days >= 0",
                "give the age in days, e.g. --older-than 7",
            )
        )
    root = data_root(args.data)
    entries = inventory(root)
    chosen = clean_candidates(
        entries,
        include_referenced=args.include_referenced,
        reports=args.reports,
        older_than_days=args.older_than,
    )
    kept = [e for e in entries if e.kind == "session" and e.used_by and e not in chosen]
    if kept:
        size = format_size(sum(e.size_bytes for e in kept))
        print(
            f"keeping {len(kept)} session(s) ({size}) that published bundles use as inputs "
            "(--include-referenced removes them too)"
        )
    if not chosen:
        print(f"nothing to clean under {root}")
        return 0
    print(_table(chosen))
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
        "clean", parents=[common], help="remove what no published bundle needs (dry run)"
    )
    p.add_argument("--yes", action="store_true", help="really remove (default: dry run)")
    p.add_argument(
        "--include-referenced",
        action="store_true",
        help="also sessions that published bundles use as inputs (their raw evidence)",
    )
    p.add_argument("--reports", action="store_true", help="also report folders")
    p.add_argument(
        "--older-than", type=float, default=0.0, metavar="DAYS", help="only older entries"
    )
    p.set_defaults(func=cmd_clean)
