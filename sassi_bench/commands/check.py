"""``sassi-bench check``: the calibration health check, and its history.

``sassi-bench check --rig R --bundle latest`` captures a few frames under the rig's
wavelength lamp, prints how far the streaks have moved from where the bundle puts them,
appends the check to the history database in the data root and exits 0 when the bundle
still holds, 1 when it should be recalibrated. ``sassi-bench check history --rig R``
writes the trend of every check as an HTML page.
"""

from __future__ import annotations

import argparse

from sassi_bench.commands.options import (
    add_bundle_options,
    add_data_option,
    add_rig_option,
    program,
)

__all__ = ["register"]


def _run(args: argparse.Namespace) -> int:
    from sassi_bench.commands.options import bundle_from_args
    from sassi_bench.procedure import load_procedure
    from sassi_bench.rig import load_rig_description, open_rig
    from sassi_bench.storage.health_history import HealthHistory, history_path
    from sassi_bench.workflows.health_check import check_light, run_health_check

    procedure = load_procedure("health_check", args.procedure)
    if args.light:
        procedure["light"] = args.light
    desc = load_rig_description(args.rig)
    check_light(desc, procedure)  # before any bundle is read or frame taken
    bundle = bundle_from_args(args, desc.name, step="check")
    rig = open_rig(desc)
    check = run_health_check(rig, bundle, procedure, data=args.data, progress=False)
    print(check.summary())
    path = history_path(args.data)
    HealthHistory(path).append(check.record())
    print(f"recorded in {path}")
    print(f"trend: {program()} check history --rig {args.rig}")
    if not check.holds:
        print(f"next: {program()} calibrate spectral --rig {args.rig}")
    return 0 if check.holds else 1


def _history(args: argparse.Namespace) -> int:
    from datetime import UTC, datetime
    from pathlib import Path

    from sassi_bench.commands.options import check_output_file
    from sassi_bench.errors import ConfigError, step_error
    from sassi_bench.plots.health import write_trend_html
    from sassi_bench.rig import load_rig_description
    from sassi_bench.storage.health_history import HealthHistory, history_path

    if args.since is not None:
        try:
            datetime.fromisoformat(args.since)
        except ValueError:
            raise ConfigError(
                step_error(
                    "check history",
                    f"--since {args.since!r} is not a date or time",
                    "give an ISO 8601 date or time, e.g. 2026-11-01 or 2026-11-01T09:00",
                )
            ) from None
    name = load_rig_description(args.rig).name
    path = history_path(args.data)
    rows = HealthHistory(path).rows(rig=name, since=args.since)
    if not rows:
        raise ConfigError(
            step_error(
                "check history",
                f"no health check of rig {name!r} is recorded in {path}",
                f"run {program()} check --rig {args.rig} first",
            )
        )
    # By default beside the history, one page per drawing: a page once written is kept.
    stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    out = Path(args.out or path.parent / f"{name}-trend-{stamp}.html")
    check_output_file("check history", str(out), "--out")
    write_trend_html(rows, out, rig=name)
    last = rows[-1]
    count = f"{len(rows)} check" + ("" if len(rows) == 1 else "s")
    print(f"{count} of {name}; latest {last['checked_utc']}: {last['verdict']}")
    print(f"trend written to {out.resolve()}")
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``check`` command (and ``check history``) to the top-level parser."""
    check = sub.add_parser(
        "check", help="health check: do the bundle's wavelengths still hold on the bench?"
    )
    add_rig_option(check)
    add_bundle_options(check)
    add_data_option(check)
    check.add_argument(
        "--light", help="lamp to check under (lamp:<name>; default: the rig's first lamp)"
    )
    check.add_argument("--procedure", help="health-check procedure YAML (default: shipped)")
    check.set_defaults(func=_run, drives_rig=True)
    check_sub = check.add_subparsers(dest="check_command", metavar="SUBCOMMAND")
    history = check_sub.add_parser("history", help="write the trend of the checks as HTML")
    add_rig_option(history)
    add_data_option(history)
    history.add_argument("--since", help="first check time to show (ISO 8601, e.g. 2026-11-01)")
    history.add_argument(
        "--out", help="HTML file (default: <data>/health/<rig>-trend-<UTC time>.html)"
    )
    history.set_defaults(func=_history, drives_rig=False)
