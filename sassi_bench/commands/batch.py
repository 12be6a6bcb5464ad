"""``sassi-bench batch assemble|validate``: many sessions at once on dask.distributed."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from sassi_bench.commands.next_steps import open_line, print_next
from sassi_bench.commands.options import (
    add_bundle_options,
    add_rig_option,
    bundle_from_args,
)
from sassi_bench.errors import ProcedureError, step_error

if TYPE_CHECKING:
    from sassi_bench.batch.run import BatchResult

#: The local dashboard's default address (as :data:`sassi_bench.batch.engine.DASHBOARD_ADDRESS`,
#: repeated so that building the parser imports no more than argparse).
DASHBOARD_ADDRESS = "127.0.0.1:0"

__all__ = ["register"]


def _batch(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.scan_plans import check_roi
    from sassi_bench.batch.engine import check_dashboard, check_scheduler
    from sassi_bench.batch.run import check_out, run_batch
    from sassi_bench.batch.select import scan_scenes, select_sessions
    from sassi_bench.rig.config import load_rig_description

    # Every argument is checked before a cluster starts.
    rig_name = load_rig_description(args.rig).name
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    dashboard = check_dashboard(args.dashboard)
    if args.workers is not None and args.workers < 1:
        raise ProcedureError(
            step_error("batch workers", f"--workers {args.workers}", "give 1 or more")
        )
    wants = ("response",) if args.kind == "assemble" else ()
    bundle = bundle_from_args(args, rig_name, step=f"batch {args.kind}", wants=wants)
    roi = check_roi(args.roi, tuple(bundle.slm_shape), "batch") if args.roi else None
    procedure = corners = None
    if args.kind == "validate":
        from sassi_bench.procedure import load_procedure
        from sassi_bench.validate.locate import grid_from_corners

        procedure = load_procedure("macbeth_validation", args.procedure)
        if args.corners:
            corners = [args.corners[i : i + 2] for i in range(0, 8, 2)]
            grid_from_corners(corners)
    out = check_out(args.out)
    scene = "colorchecker" if args.kind == "validate" else None
    sessions = select_sessions(None if args.all else args.sessions, data=args.data, scene=scene)
    if args.all and scene is not None:
        others = sorted(
            f"{s} ({seen or 'scene unknown'})"
            for s, seen in scan_scenes(args.data).items()
            if s not in sessions
        )
        if others:
            print(
                f"{len(sessions)} ColorChecker scan(s); not charts, left out: {', '.join(others)}"
            )
    batch = run_batch(
        args.kind, sessions, bundle, out, data=args.data, scheduler=args.scheduler,
        workers=args.workers, roi=roi, procedure=procedure, corners=corners,
        progress=not args.quiet, dashboard=dashboard,
    )  # fmt: skip
    counts = {s: sum(r.status == s for r in batch.results) for s in ("done", "skipped", "failed")}
    print(
        f"{len(batch.results)} sessions in {batch.seconds:.1f} s on {batch.workers} workers: "
        + ", ".join(f"{n} {s}" for s, n in counts.items())
    )
    for result in batch.failed:
        print(f"  FAILED {result.session}: {result.error}")
    print(f"summary: {batch.summary_csv}\n         {batch.summary_html}")
    if batch.failed:
        print("each failed session's error says what went wrong; no session was changed. Fix the")
        print("cause (or leave those sessions out with --sessions), then run the same command")
        print("again: finished outputs are skipped")
        return 1
    _print_next(batch, out)
    return 0


#: What each batch writes per session, as its summary names it.
OUTPUTS = {
    "assemble": "the cubes, one <session>.nc",
    "validate": "the scores, one <session>.macbeth.json",
}


def _print_next(batch: BatchResult, out: Path) -> None:
    """Where a finished batch's results are: its summary page to open, and every session's
    output in ``out``."""
    print_next([(open_line(batch.summary_html), "every session's status, time and output")])
    print(f"  {OUTPUTS[batch.kind]} per session, in {out}")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``batch`` group to the top-level parser."""
    batch = sub.add_parser("batch", help="assemble or validate many sessions on dask.distributed")
    kinds = batch.add_subparsers(dest="kind", metavar="KIND", required=True)
    helps = {
        "assemble": "assemble pinhole-scan sessions into cubes (<out>/<session>.nc)",
        "validate": "Macbeth CIEDE2000 of ColorChecker scans (white patch as white reference)",
    }
    for kind, text in helps.items():
        p = kinds.add_parser(kind, help=text)
        which = p.add_mutually_exclusive_group(required=True)
        which.add_argument("--sessions", metavar="PATTERN", help="session ids, e.g. 'scan-*'")
        every = "every ColorChecker scan" if kind == "validate" else "every pinhole-scan session"
        which.add_argument("--all", action="store_true", help=every)
        add_rig_option(p)
        add_bundle_options(p)
        p.add_argument("--data", help="data root, shared by every worker")
        p.add_argument("--out", required=True, help="output folder, shared by every worker")
        p.add_argument(
            "--scheduler", metavar="ADDRESS", help="tcp://host:port of a dask scheduler "
            "(default: a local cluster on this machine)",
        )  # fmt: skip
        p.add_argument("--workers", type=int, help="local cluster workers (default: one per CPU)")
        p.add_argument(
            "--dashboard", metavar="HOST:PORT", default=DASHBOARD_ADDRESS,
            help=f"the local cluster's dashboard (default {DASHBOARD_ADDRESS}: this machine "
            "only, any free port); 0.0.0.0:8787 opens it to the network on purpose (it shows "
            "task names, paths and logs); none: no dashboard",
        )  # fmt: skip
        p.add_argument("--roi", type=int, nargs=4, metavar=("ROW0", "COL0", "ROW1", "COL1"))
        if kind == "validate":
            p.add_argument("--procedure", help="procedure YAML (default: macbeth_validation)")
            p.add_argument(
                "--corners", type=float, nargs=8,
                metavar=("U1", "V1", "U6", "V6", "U24", "V24", "U19", "V19"),
                help="SLM (u, v) centres of patches 1, 6, 24 and 19 in every scan, instead of "
                "detecting the chart",
            )  # fmt: skip
        p.add_argument("--quiet", action="store_true", help="no progress bar")
        p.set_defaults(func=_batch)
