"""``sassi-bench validate macbeth|snapshot``: the ColorChecker and snapshot validations."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from sassi_bench.commands.next_steps import command, open_line, print_next
from sassi_bench.commands.options import (
    add_bundle_options,
    add_data_option,
    add_rig_option,
    bundle_from_args,
    check_new_files,
    check_output_folder,
    new_session,
    print_checks,
)

if TYPE_CHECKING:
    from sassi_bench.bundle import CalibrationBundle

__all__ = ["register"]

#: What each validation writes into its --out folder.
MACBETH_REPORT = ("macbeth_report.html", "macbeth_report.json")
SNAPSHOT_REPORT = ("snapshot_report.html", "snapshot_report.json", "scan.nc")


def _procedure(args) -> dict:
    from sassi_bench.procedure import load_procedure

    procedure = load_procedure("macbeth_validation", args.procedure)
    if args.white:
        procedure["white_reference"]["source"] = args.white
    if args.reference:
        procedure["reference"]["data"] = args.reference
    if args.corners:
        procedure["localisation"]["method"] = "corners"
    return procedure


def _macbeth(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.plan_geometry import planned_macbeth
    from sassi_bench.rig import open_rig
    from sassi_bench.validate.locate import grid_from_corners
    from sassi_bench.validate.reference import reference_chart
    from sassi_bench.validate.report import write_report
    from sassi_bench.workflows.macbeth import run_macbeth
    from sassi_bench.workflows.scan import check_scan

    rig = open_rig(args.rig)
    procedure = planned_macbeth(_procedure(args), rig.description)
    scan_cfg = procedure["scan"]
    roi = tuple(args.roi) if args.roi else None
    check_scan(rig, scan_cfg["scene"], scan_cfg["light"], tuple(scan_cfg["pitch_px"]), roi)
    reference_chart(procedure["reference"]["data"])
    corners = None
    if args.corners:
        corners = [args.corners[i : i + 2] for i in range(0, 8, 2)]
        grid_from_corners(corners)
    check_output_folder("validate macbeth", args.out)
    check_new_files("validate macbeth", [Path(args.out) / name for name in MACBETH_REPORT])
    bundle = bundle_from_args(args, rig.description.name, step="validate macbeth")
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
    status = _print_verdict(result, html_path, json_path)
    _print_next(args, bundle, html_path, result.passed, "check")
    return status


def _snapshot(args: argparse.Namespace) -> int:
    from sassi_bench.procedure import load_procedure
    from sassi_bench.rig import open_rig
    from sassi_bench.rig.rig import check_scene
    from sassi_bench.validate.snapshot_report import write_snapshot_report
    from sassi_bench.workflows.snapshot import check_inputs
    from sassi_bench.workflows.snapshot_validation import run_snapshot

    procedure = load_procedure("snapshot_validation", args.procedure)
    check_scene(args.scene, step="validate snapshot")
    check_output_folder("validate snapshot", args.out)
    check_new_files("validate snapshot", [Path(args.out) / name for name in SNAPSHOT_REPORT])
    rig = open_rig(args.rig)
    bundle = bundle_from_args(
        args,
        rig.description.name,
        step="validate snapshot",
        needs=("guide_homography",),
        wants=("response",),
    )
    check_inputs(rig, bundle, args.scene)  # before any session is created
    new_session(args, "session", f"snapshot-{args.scene}")
    result = run_snapshot(
        rig, bundle, procedure, scene=args.scene, scan_path=args.scan, low_light=args.low_light,
        video_frames=args.video, mask_path=args.mask, session_id=args.session, data=args.data,
        progress=not args.quiet,
    )  # fmt: skip
    html_path, json_path = write_snapshot_report(result, args.out, procedure["scoring"]["points"])
    if result.scan_dataset is not None:
        from sassi_bench.spectra.cube_io import write_netcdf

        scan_path = write_netcdf(result.scan_dataset, Path(args.out) / "scan.nc")
        print(f"  scan cube: {scan_path} (reuse it with --scan)")
    print(f"\nSnapshot validation of bundle {bundle.rig_name}/{bundle.version} on rig "
          f"{result.rig_name}, scene {result.scene}")  # fmt: skip
    for name, run in result.runs.items():
        for method, s in run.scores.items():
            print(
                f"  {name:18s} {method:7s} PSNR {s.psnr_db:6.2f} dB, affine {s.psnr_affine_db:6.2f}"
                f" dB, SSIM {s.ssim:.3f}, angle {s.spectral_angle_deg:5.2f} deg"
            )
    split = next(iter(result.runs.values())).error_split
    print(
        f"  where the error comes from: spectra at the open pixels {split['samples_psnr_db']:.2f}"
        f" dB against the scan; rank-1 from the scan's own spectra there "
        f"{split['rank1_from_scan_psnr_db']:.2f} dB (the mask's limit)"
    )
    for frame in result.video:
        print(
            f"  video frame {frame['frame']:3d}  rank-1 {frame['rank1']['psnr_affine_db']:6.2f} dB,"
            f" guided {frame['guided']['psnr_affine_db']:6.2f} dB (affine)"
        )
    status = _print_verdict(result, html_path, json_path)
    _print_next(args, bundle, html_path, result.passed, "snapshot take")
    return status


def _print_verdict(result, html_path, json_path) -> int:
    """Print a validation's checks and where its report is; the exit status (1: failed)."""
    print_checks(result.checks, name_width=24)
    print(f"  report: {html_path}\n  data:   {json_path}")
    print("VALIDATION PASSED" if result.passed else "VALIDATION FAILED")
    return 0 if result.passed else 1


#: What a lab runs once a validation passed, with the bundle it validated.
AFTER_PASS = {
    "check": "a health check now: the baseline later checks are compared with",
    "snapshot take": "snapshots with the validated bundle (cubes and a quick look in snapshots/)",
}


def _print_next(
    args: argparse.Namespace, bundle: CalibrationBundle, html_path: Path, passed: bool, after: str
) -> None:
    """The report to read and, when the validation passed, the command ``after`` (a key of
    :data:`AFTER_PASS`) with the bundle validated: its version (another command's ``latest``
    may be another bundle), or the folder ``--bundle`` named."""
    from sassi_bench.bundle.errors import BundleError
    from sassi_bench.bundle.layout import normalize_version

    steps = [(open_line(html_path), "the validation report, with every figure and check")]
    if passed:
        try:
            normalize_version(args.bundle or "latest")
        except BundleError:
            ref = args.bundle  # a bundle folder, named as given
        else:
            ref = bundle.version
        options = {"--rig": args.rig, "--bundle": ref, "--bundle-rig": args.bundle_rig}
        options["--data"] = args.data
        if after == "snapshot take":
            options.update({"--scene": args.scene, "--out": "snapshots"})
        steps.append((command(after, options), AFTER_PASS[after]))
    print_next(steps)


def _report_options(parser: argparse.ArgumentParser, procedure: str) -> None:
    """The options every validation shares: rig, bundle, data root, report folder and
    procedure file."""
    add_rig_option(parser)
    add_bundle_options(parser)
    add_data_option(parser)
    parser.add_argument("--out", required=True, help="folder for the HTML and JSON report")
    parser.add_argument(
        "--procedure", help=f"procedure YAML (default: procedures/{procedure}.yaml)"
    )


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``validate`` command group to the top-level parser."""
    validate = sub.add_parser("validate", help="validate a calibration bundle")
    groups = validate.add_subparsers(dest="validate_command", metavar="CHECK", required=True)
    macbeth = groups.add_parser(
        "macbeth",
        help="scan a ColorChecker, compare with reference reflectances, write an HTML report",
    )
    _report_options(macbeth, "macbeth_validation")
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
        drives_rig=True,
    )

    snapshot = groups.add_parser(
        "snapshot",
        help="scan a scene, take SASSI snapshots, reconstruct them, score against the scan",
    )
    _report_options(snapshot, "snapshot_validation")
    snapshot.add_argument(
        "--scene", default="natural", help="natural, colorchecker, pcb or white (default: natural)"
    )
    snapshot.add_argument(
        "--scan", help="a scan cube (NetCDF) to score against instead of scanning"
    )
    snapshot.add_argument(
        "--low-light", action="store_true", help="also take a photon-starved snapshot"
    )
    snapshot.add_argument(
        "--video", type=int, default=0, metavar="N", help="also take N frames of a moving scene"
    )
    snapshot.add_argument(
        "--mask", help="a mask (.npy, (H, W) bool) to use instead of the adaptive one"
    )
    snapshot.add_argument("--session", help="session id prefix; an existing one resumes")
    snapshot.add_argument("--quiet", action="store_true", help="no progress bars")
    snapshot.set_defaults(
        func=_snapshot, resume_options=(("session", "--session"),), drives_rig=True
    )
