"""``sassi-bench scan`` and ``sassi-bench calibrate response``."""

from __future__ import annotations

import argparse
from pathlib import Path

from sassi_bench.bundle.cli import add_bundle_options
from sassi_bench.cli import new_session

__all__ = ["register", "register_response"]


def _bundle(args):
    from sassi_bench.bundle.cli import bundle_from_args

    return bundle_from_args(args, args.rig_name)


def _check_output(path: str, option: str) -> None:
    """Refuse an output file whose folder does not exist, before anything is captured."""
    from sassi_bench.errors import ProcedureError, step_error

    folder = Path(path).resolve().parent
    if not folder.is_dir():
        raise ProcedureError(
            step_error("scan", f"{option} {path}: the folder {folder} does not exist", "create it")
        )


def _scan(args: argparse.Namespace) -> int:
    from sassi_bench.rig import open_rig
    from sassi_bench.spectra.cube_io import write_envi, write_netcdf
    from sassi_bench.workflows.scan import check_scan, run_scan

    rig = open_rig(args.rig)
    roi = tuple(args.roi) if args.roi else None
    check_scan(rig, args.scene, args.light, tuple(args.pitch), roi)
    _check_output(args.out, "--out")
    if args.envi:
        _check_output(args.envi, "--envi")
    args.rig_name = rig.description.name
    bundle = _bundle(args)
    new_session(args, "session", f"scan-{args.scene}")
    run = run_scan(
        rig, bundle, scene=args.scene, light=args.light, pitch=tuple(args.pitch), roi=roi,
        session_id=args.session, data=args.data, progress=not args.quiet,
    )  # fmt: skip
    ds = run.dataset()
    out = write_netcdf(ds, args.out)
    print(f"cube {ds['radiance'].shape} ({ds['radiance'].attrs['units']}) -> {out}")
    if args.envi:
        print(f"ENVI -> {write_envi(ds, args.envi)}")
    bad = int((run.scan.quality != 0).sum())
    print(f"flagged pixels: {bad}; problems: {len(run.scan.problems)}")
    for line in run.scan.problems[:10]:
        print(f"  {line}")
    return 0


def _response(args: argparse.Namespace) -> int:
    from sassi_bench.rig import open_rig
    from sassi_bench.workflows.scan import check_scan, response_source, run_response

    rig = open_rig(args.rig)
    check_scan(rig, "white", args.light, (100, 5))
    response_source(rig, args.temperature, args.reference)
    args.rig_name = rig.description.name
    bundle = _bundle(args)
    new_session(args, "session", "response")
    path = run_response(
        rig, bundle, light=args.light, temperature_k=args.temperature, reference_csv=args.reference,
        session_id=args.session, data=args.data, progress=not args.quiet,
        allow_failed=args.allow_failed,
    )  # fmt: skip
    print(f"bundle with radiometric response: {path}")
    return 0


def _common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--rig", default="sim", help="rig name or YAML path (default: sim)")
    add_bundle_options(parser)
    parser.add_argument("--data", help="data root for sessions and bundles")
    parser.add_argument("--session", help="session id; an existing one resumes its capture")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    parser.set_defaults(resume_options=(("session", "--session"),))


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``scan`` to the top-level parser."""
    scan = sub.add_parser("scan", help="Nyquist pinhole scan of a scene into a reference cube")
    _common(scan)
    scan.add_argument("--scene", default="colorchecker", help="scene (default: colorchecker)")
    scan.add_argument("--light", default="led", help="light (default: led)")
    scan.add_argument("--pitch", type=int, nargs=2, default=[100, 5], metavar=("PX", "PY"))
    scan.add_argument("--roi", type=int, nargs=4, metavar=("ROW0", "COL0", "ROW1", "COL1"))
    scan.add_argument("--out", required=True, help="NetCDF file to write")
    scan.add_argument("--envi", help="also export ENVI (.hdr/.img) at this path")
    scan.set_defaults(func=_scan)


def register_response(groups: argparse._SubParsersAction) -> None:
    """Add ``response`` to the ``calibrate`` group."""
    resp = groups.add_parser(
        "response", help="radiometric response from a white diffuser; publishes a new bundle"
    )
    _common(resp)
    resp.add_argument("--light", default="halogen", help="source (default: halogen)")
    resp.add_argument("--temperature", type=float, help="blackbody temperature (K) of the source")
    resp.add_argument("--reference", help="CSV of the source spectrum (wavelength_nm,power)")
    resp.add_argument("--allow-failed", action="store_true", help="publish even if a check failed")
    resp.set_defaults(func=_response)
