"""``sassi-bench calibrate``: run calibration procedures on a rig."""

from __future__ import annotations

import argparse

__all__ = ["register"]


def _spectral(args: argparse.Namespace) -> int:
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.procedure import load_procedure
    from sassi_bench.workflows.spectral import run_spectral_calibration

    procedure = load_procedure("spectral_calibration", args.procedure)
    rig = open_rig(args.rig)
    result = run_spectral_calibration(
        rig,
        procedure,
        session_id=args.session,
        data=args.data,
        progress=not args.quiet,
        publish_bundle=not args.no_publish,
        allow_failed=args.allow_failed,
    )
    print(f"\nspectral calibration of rig {rig.description.name!r}")
    for check in result.checks:
        mark = "PASS" if check.passed else "FAIL"
        limit = f"{check.comparison} {check.tolerance:g} {check.unit}"
        print(f"  {mark}  {check.name:32s} {check.value:10.4f} {limit}")
    print(
        f"  {result.dispersion.bins.count} wavelength bins, "
        f"{result.dispersion.bins.centres_nm[0]:.1f}-{result.dispersion.bins.centres_nm[-1]:.1f} nm"
    )
    print(f"  sessions: {', '.join(str(s.path) for s in result.sessions)}")
    if result.bundle_path is not None:
        print(f"  bundle: {result.bundle_path}")
    print("all tolerances passed" if result.passed else "SOME TOLERANCES FAILED")
    return 0 if result.passed else 1


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` command group to the top-level parser."""
    calibrate = sub.add_parser("calibrate", help="run calibration procedures")
    groups = calibrate.add_subparsers(dest="calibrate_command", metavar="PROCEDURE", required=True)
    spectral = groups.add_parser(
        "spectral", help="laser sweeps, dispersion and blur fits; publishes a bundle"
    )
    spectral.add_argument("--rig", default="sim", help="rig name or YAML path (default: sim)")
    spectral.add_argument(
        "--procedure", help="procedure YAML (default: procedures/spectral_calibration.yaml)"
    )
    spectral.add_argument("--data", help="data root for sessions and bundles")
    spectral.add_argument("--session", help="session id; an existing one resumes its capture")
    spectral.add_argument(
        "--allow-failed",
        action="store_true",
        help="publish even if a tolerance failed (marked failed)",
    )
    spectral.add_argument("--no-publish", action="store_true", help="do not publish a bundle")
    spectral.add_argument("--quiet", action="store_true", help="no progress bars")
    spectral.set_defaults(func=_spectral)
    from sassi_bench.spectra.cli import register_response

    register_response(groups)
