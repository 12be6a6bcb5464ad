"""``sassi-bench validate macbeth``: the ColorChecker validation of a bundle."""

from __future__ import annotations

import argparse
from pathlib import Path

from sassi_bench.bundle.cli import add_bundle_options
from sassi_bench.cli import new_session
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["register"]


def _bundle(args):
    from sassi_bench.bundle.cli import bundle_from_args

    return bundle_from_args(args, args.rig_name)


def _procedure(args) -> dict:
    from sassi_bench.workflows.procedure import load_procedure

    procedure = load_procedure("macbeth_validation", args.procedure)
    if args.white:
        procedure["white_reference"]["source"] = args.white
    if args.reference:
        procedure["reference"]["data"] = args.reference
    if args.corners:
        procedure["localisation"]["method"] = "corners"
    return procedure


def _macbeth(args: argparse.Namespace) -> int:
    from sassi_bench.bundle.quality import unit_suffix
    from sassi_bench.rig import open_rig
    from sassi_bench.validate.locate import grid_from_corners
    from sassi_bench.validate.reference import reference_chart
    from sassi_bench.validate.report import write_report
    from sassi_bench.validate.run import run_macbeth
    from sassi_bench.workflows.scan import check_scan

    procedure = _procedure(args)
    rig = open_rig(args.rig)
    scan_cfg = procedure["scan"]
    roi = tuple(args.roi) if args.roi else None
    check_scan(rig, scan_cfg["scene"], scan_cfg["light"], tuple(scan_cfg["pitch_px"]), roi)
    reference_chart(procedure["reference"]["data"])
    corners = None
    if args.corners:
        corners = [args.corners[i : i + 2] for i in range(0, 8, 2)]
        grid_from_corners(corners)
    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise ProcedureError(
            step_error("validate macbeth", f"--out {args.out} is a file", "give a folder")
        )
    args.rig_name = rig.description.name
    bundle = _bundle(args)
    new_session(args, "session", f"scan-{scan_cfg['scene']}")
    if procedure["white_reference"]["source"] == "diffuser":
        scene = procedure["white_reference"]["diffuser_scene"]
        new_session(args, "white_session", f"scan-{scene}")
    result = run_macbeth(
        rig, bundle, procedure, corners=corners, session_id=args.session,
        white_session_id=args.white_session, roi=roi,
        data=args.data, progress=not args.quiet,
    )  # fmt: skip
    html_path, json_path = write_report(result, bundle, procedure, args.out)
    lo, hi = result.band_nm
    print(f"\nMacbeth validation of bundle {bundle.rig_name}/{bundle.version}")
    white = procedure["white_reference"]["source"]
    print(f"  usable band {lo:.0f}-{hi:.0f} nm; white reference: {white}")
    for check in result.checks:
        mark = "PASS" if check.passed else "FAIL"
        limit = f"{check.comparison} {check.tolerance:g}{unit_suffix(check.unit)}"
        print(f"  {mark}  {check.name:24s} {check.value:10.4f} {limit}")
    print(f"  report: {html_path}\n  data:   {json_path}")
    print("VALIDATION PASSED" if result.passed else "VALIDATION FAILED")
    return 0 if result.passed else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``validate`` command group to the top-level parser."""
    validate = sub.add_parser("validate", help="validate a calibration bundle")
    groups = validate.add_subparsers(dest="validate_command", metavar="CHECK", required=True)
    macbeth = groups.add_parser(
        "macbeth",
        help="scan a ColorChecker, compare with reference reflectances, write an HTML report",
    )
    macbeth.add_argument("--rig", default="sim", help="rig name or YAML path (default: sim)")
    add_bundle_options(macbeth)
    macbeth.add_argument("--data", help="data root for sessions and bundles")
    macbeth.add_argument("--out", required=True, help="folder for the HTML and JSON report")
    macbeth.add_argument(
        "--procedure", help="procedure YAML (default: procedures/macbeth_validation.yaml)"
    )
    macbeth.add_argument(
        "--white", choices=["diffuser", "patch"], help="white reference (default: procedure's)"
    )
    macbeth.add_argument(
        "--reference", help="reference data: 'BabelColor Average', 'ColorChecker N Ohta' or CSV"
    )
    macbeth.add_argument(
        "--corners",
        type=float,
        nargs=8,
        metavar=("U1", "V1", "U6", "V6", "U24", "V24", "U19", "V19"),
        help="SLM (u, v) centres of patches 1, 6, 24 and 19 instead of automatic detection",
    )
    macbeth.add_argument("--session", help="chart scan session id; an existing one is reused")
    macbeth.add_argument("--white-session", help="diffuser scan session id; reused if it exists")
    macbeth.add_argument("--roi", type=int, nargs=4, metavar=("ROW0", "COL0", "ROW1", "COL1"))
    macbeth.add_argument("--quiet", action="store_true", help="no progress bars")
    macbeth.set_defaults(
        func=_macbeth,
        resume_options=(("session", "--session"), ("white_session", "--white-session")),
    )
