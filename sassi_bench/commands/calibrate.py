"""``sassi-bench calibrate``: the whole chain, or one procedure (``spectral``, ``response``,
``guide``) on a rig."""

from __future__ import annotations

import argparse
from pathlib import Path

from sassi_bench.commands.next_steps import command, open_line, print_next
from sassi_bench.commands.options import (
    add_bundle_options,
    add_data_option,
    add_rig_option,
    add_simulate_option,
    bundle_from_args,
    check_new_files,
    check_output_folder,
    new_session,
    print_checks,
)

__all__ = ["register"]

#: The report the whole chain leaves in its --out folder.
MACBETH_REPORT = ("macbeth_report.html", "macbeth_report.json")


def _print_notes(notes: list[str]) -> None:
    for note in notes:
        print(f"  note: {note}")


def _full(args: argparse.Namespace) -> int:
    from sassi_bench.paths import data_root
    from sassi_bench.procedure import load_procedure
    from sassi_bench.reduce.spectral import spectral_notes
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.full import run_full_calibration

    procedure = load_procedure("full_calibration", args.procedure)
    rig = open_rig(args.rig, simulate=args.simulate)
    check_output_folder("calibrate", args.out, "give a folder for the report")
    new_session(args, "session", "full")
    report_dir = Path(args.out) if args.out else data_root(args.data) / "reports" / args.session
    check_new_files(
        "calibrate", [report_dir / name for name in MACBETH_REPORT], "--out folder or --session"
    )
    result = run_full_calibration(
        rig,
        procedure,
        session_id=args.session,
        data=args.data,
        out=args.out,
        progress=not args.quiet,
        allow_failed=args.allow_failed,
    )
    print(f"\nfull calibration of rig {rig.description.name!r}")
    print_checks(result.checks)
    _print_notes(spectral_notes(result.stages["spectral"]))
    if result.bundle_path is not None:
        print(f"  bundle: {result.bundle_path}")
    else:
        print("  bundle: not published (a tolerance failed; --allow-failed publishes it marked)")
    print(f"  report: {result.report_html}")
    _print_data_use(result.stages["staging"], result.bundle_path, args.data)
    for line in result.kept.lines():
        print(f"  raw frames {line}")
    print("all tolerances passed" if result.passed else "SOME TOLERANCES FAILED")
    _print_next(args, result.bundle_path, result.report_html)
    return 0 if result.passed else 1


def _print_next(args: argparse.Namespace, bundle_path: Path | None, report: Path) -> None:
    """The commands a lab runs after a calibration: a health check right away (the
    baseline later checks are compared with), a snapshot with the new bundle, and the
    report to read."""
    steps = []
    if bundle_path is not None:
        bundle = {"--rig": args.rig, "--bundle": bundle_path.name, "--data": args.data}
        check = "a health check now: the baseline later checks are compared with"
        steps.append((command("check", bundle), check))
        snapshot = "a snapshot with the new bundle (cubes and a quick look in snapshots/)"
        steps.append((command("snapshot take", {**bundle, "--out": "snapshots"}), snapshot))
    report_line = "the Macbeth validation report, with every quality check of the bundle"
    steps.append((open_line(report), report_line))
    print_next(steps)
    if bundle_path is not None:
        figures = sorted(p.name for p in (Path(bundle_path) / "report").glob("*.png"))
        if figures:
            print(f"  the bundle's figures, in {Path(bundle_path) / 'report'}:")
            print("      " + ", ".join(figures))


#: The stage a lab runs after each single calibration stage, on the bundle it published,
#: and what it is for.
STAGE_NEXT = {
    "spectral": (
        "calibrate response",
        "the radiometric response from a white diffuser, on the new bundle",
    ),
    "response": ("calibrate guide", "the guide camera -> SLM homography, on the new bundle"),
    "guide": ("validate macbeth", "the Macbeth validation of the new bundle (an HTML report)"),
}


def stage_next(args: argparse.Namespace, stage: str, bundle_path: Path) -> tuple[str, str]:
    """The command that follows calibration ``stage`` on the bundle it published at
    ``bundle_path``, and what it is for.

    Examples
    --------
    >>> args = argparse.Namespace(rig="sim", data=None, simulate=False, allow_failed=False)
    >>> stage_next(args, "spectral", Path("bundles/sim/v0004"))[0]
    'sassi-bench calibrate response --rig sim --bundle v0004'
    """
    words, why = STAGE_NEXT[stage]
    options = {"--rig": args.rig, "--bundle": bundle_path.name, "--data": args.data}
    if words == "validate macbeth":
        options["--out"] = "macbeth-report"
    else:  # the next stage drives the rig, and takes a failed parent, as this one did
        options.update({"--simulate": args.simulate, "--allow-failed": args.allow_failed})
    return command(words, options), why


def _print_data_use(staging: Path, bundle_path: Path | None, data: str | None) -> None:
    """Where the run's raw data went, how big it is, and how to clean up."""
    from sassi_bench.commands.options import program
    from sassi_bench.storage.inventory import folder_size, format_size

    size, _ = folder_size(staging)
    kept = f", the inputs of {bundle_path.parent.name}/{bundle_path.name}" if bundle_path else ""
    where = f" --data {data}" if data else ""
    print(f"  raw data: {staging} ({format_size(size)}: this run's sessions{kept})")
    print(
        f"  disk: `{program()} data list{where}` shows everything kept; "
        f"`{program()} data clean{where}` what can go (a dry run; its raw frames need "
        "--include-referenced)"
    )


def _spectral(args: argparse.Namespace) -> int:
    from sassi_bench.procedure import load_procedure
    from sassi_bench.reduce.spectral import spectral_notes
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.spectral import run_spectral_calibration

    procedure = load_procedure("spectral_calibration", args.procedure)
    rig = open_rig(args.rig, simulate=args.simulate)
    new_session(args, "session", "spectral")
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
    print_checks(result.checks)
    _print_notes(spectral_notes(result))
    print(
        f"  {result.dispersion.bins.count} wavelength bins, "
        f"{result.dispersion.bins.centres_nm[0]:.1f}-{result.dispersion.bins.centres_nm[-1]:.1f} nm"
    )
    print(f"  sessions: {', '.join(str(s.path) for s in result.sessions)}")
    if result.bundle_path is not None:
        print(f"  bundle: {result.bundle_path}")
    print("all tolerances passed" if result.passed else "SOME TOLERANCES FAILED")
    if result.bundle_path is not None:
        print_next([stage_next(args, "spectral", result.bundle_path)])
    return 0 if result.passed else 1


def _response(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.plan_geometry import scan_pitch
    from sassi_bench.reduce.response import response_source
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.scan import check_scan, run_response

    rig = open_rig(args.rig, simulate=args.simulate)
    check_scan(rig, "white", args.light, scan_pitch(rig.description))
    response_source(rig.description, args.temperature, args.reference)
    bundle = bundle_from_args(args, rig.description.name, step="calibrate response")
    new_session(args, "session", "response")
    path = run_response(
        rig, bundle, light=args.light, temperature_k=args.temperature, reference_csv=args.reference,
        session_id=args.session, data=args.data, progress=not args.quiet,
        allow_failed=args.allow_failed,
    )  # fmt: skip
    print(f"bundle with radiometric response: {path}")
    print_next([stage_next(args, "response", path)])
    return 0


def _guide(args: argparse.Namespace) -> int:
    from sassi_bench.procedure import load_procedure
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.guide import run_guide_registration

    procedure = load_procedure("guide_registration", args.procedure)
    if args.full:
        procedure["scan"]["stride_px"] = [1, 1]
    rig = open_rig(args.rig, simulate=args.simulate)
    bundle = bundle_from_args(
        args, rig.description.name, step="calibrate guide", wants=("response",)
    )
    new_session(args, "session", "guide")
    result = run_guide_registration(
        rig,
        bundle,
        procedure,
        session_id=args.session,
        data=args.data,
        progress=not args.quiet,
        publish_bundle=not args.no_publish,
        allow_failed=args.allow_failed,
    )
    q = result.registration.quality
    print(f"\nguide -> SLM registration of rig {rig.description.name!r} (bundle {bundle.version})")
    print(f"  rendering: {result.reference.rendering}; scan stride {list(result.reference.stride)}")
    print_checks(result.checks)
    if q.dense_correlation is not None:
        print(f"  dense refinement: correlation {q.dense_correlation:.4f}")
    print("  homography (guide p, q, 1 -> SLM u, v, 1):")
    for row in result.homography:
        print("    " + "  ".join(f"{x: .6e}" for x in row))
    if result.bundle_path is not None:
        print(f"  bundle: {result.bundle_path}")
    print("all tolerances passed" if result.passed else "SOME TOLERANCES FAILED")
    if result.bundle_path is not None:
        print_next([stage_next(args, "guide", result.bundle_path)])
    return 0 if result.passed else 1


def _run_arguments(parser: argparse.ArgumentParser, kind: str | None, publish: bool = True) -> None:
    """The options every calibration procedure takes (``kind``: its procedure YAML)."""
    add_rig_option(parser)
    add_simulate_option(parser)
    if kind is not None:
        parser.add_argument("--procedure", help=f"procedure YAML (default: procedures/{kind}.yaml)")
    add_data_option(parser)
    parser.add_argument("--session", help="session id; an existing one resumes its capture")
    parser.add_argument(
        "--allow-failed", action="store_true", help="publish even if a tolerance failed"
    )
    if publish:
        parser.add_argument("--no-publish", action="store_true", help="do not publish a bundle")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.set_defaults(resume_options=(("session", "--session"),), drives_rig=True)


def _register_response(groups: argparse._SubParsersAction) -> None:
    resp = groups.add_parser(
        "response", help="radiometric response from a white diffuser; publishes a new bundle"
    )
    _run_arguments(resp, None, publish=False)
    add_bundle_options(resp)
    resp.add_argument("--light", default="halogen", help="source (default: halogen)")
    resp.add_argument("--temperature", type=float, help="blackbody temperature (K) of the source")
    resp.add_argument("--reference", help="CSV of the source spectrum (wavelength_nm,power)")
    resp.set_defaults(func=_response)


def _register_guide(groups: argparse._SubParsersAction) -> None:
    guide = groups.add_parser(
        "guide", help="guide camera -> SLM homography from a scan; publishes a new bundle"
    )
    _run_arguments(guide, "guide_registration")
    add_bundle_options(guide)
    guide.add_argument(
        "--full", action="store_true", help="full Nyquist scan instead of the coarse route"
    )
    guide.set_defaults(func=_guide)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``calibrate`` command group to the top-level parser."""
    calibrate = sub.add_parser(
        "calibrate",
        help="run calibration procedures (no PROCEDURE: the whole chain)",
        description=(
            "Without a PROCEDURE, run the whole chain from procedures/full_calibration.yaml: "
            "spectral sweeps and fits, radiometric response, guide homography and Macbeth "
            "validation, publishing one bundle and its report."
        ),
    )
    _run_arguments(calibrate, "full_calibration", publish=False)
    calibrate.add_argument("--out", help="report folder (default: <data>/reports/<session>)")
    calibrate.set_defaults(func=_full)
    groups = calibrate.add_subparsers(dest="calibrate_command", metavar="PROCEDURE")
    spectral = groups.add_parser(
        "spectral", help="laser sweeps, dispersion and blur fits; publishes a bundle"
    )
    _run_arguments(spectral, "spectral_calibration")
    spectral.set_defaults(func=_spectral)
    _register_response(groups)
    _register_guide(groups)
