"""``sassi-bench bundle ...``: list, show, verify, diff, export and import calibration bundles.

Every subcommand accepts ``--data DIR`` (the data root; see :func:`sassi_bench.paths.data_root`).
A bundle is named the same way everywhere (:func:`~sassi_bench.bundle.layout.resolve_bundle_ref`):
a version of ``--rig`` (``v0003``, ``3`` or ``latest``) or the path of its folder (``verify``
also takes an exported zip). ``export --format sassi-mat`` writes the files of the SASSI
authors' reconstruction code (:mod:`sassi_bench.export.sassi_mat`).

Examples
--------
Not run here (it runs a command on a rig and its data)::

    from sassi_bench.commands import main
    main(["bundle", "list", "--data", "calib_data"])
    main(["bundle", "diff", "v0001", "latest", "--rig", "sim"])
    main(["bundle", "export", "latest", "--format", "sassi-mat",
          "--out", "for_sassi"])
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sassi_bench.commands.options import DATA_HELP, latest_problem, load_bundle_ref, program
from sassi_bench.errors import ProcedureError, step_error

if TYPE_CHECKING:
    import numpy as np

    from sassi_bench.bundle import CalibrationBundle

__all__ = [
    "describe",
    "offset_text",
    "parse_quantum",
    "parse_wavelengths",
    "register",
]

DEFAULT_RIG = "sim"


def register(subparsers: Any) -> None:
    """Add the ``bundle`` command group to the top-level subparsers.

    Parameters
    ----------
    subparsers
        What ``ArgumentParser.add_subparsers()`` returned.

    Examples
    --------
    >>> import argparse
    >>> parser = argparse.ArgumentParser(prog="sassi-bench")
    >>> register(parser.add_subparsers())
    >>> parser.parse_args(["bundle", "verify", "calib_data/sim/v0001"]).func.__name__
    'cmd_verify'
    """
    parser = subparsers.add_parser(
        "bundle",
        help="list, inspect, verify, compare, export and import calibration bundles",
        description="Work with versioned calibration bundles (<data>/<rig>/<version>/).",
    )
    sub = parser.add_subparsers(dest="bundle_command", metavar="SUBCOMMAND", required=True)
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--data", metavar="DIR", default=None, help=DATA_HELP)
    rig_help = f"rig name (default: {DEFAULT_RIG})"
    ref_help = "a version of --rig (v0003, 3, latest) or a bundle folder"

    p = sub.add_parser("list", parents=[common], help="table of published versions")
    p.add_argument("--rig", default=None, help="only this rig (default: every rig)")
    p.set_defaults(func=cmd_list)

    p = sub.add_parser("show", parents=[common], help="summary of one bundle (verifies it first)")
    p.add_argument("version", metavar="VERSION", nargs="?", default="latest", help=ref_help)
    p.add_argument("--rig", default=DEFAULT_RIG, help=rig_help)
    p.set_defaults(func=cmd_show)

    p = sub.add_parser("verify", parents=[common], help="check the schema and every checksum")
    p.add_argument(
        "path", metavar="VERSION", nargs="?", default="latest", help=ref_help + ", or a .zip"
    )
    p.add_argument("--rig", default=DEFAULT_RIG, help=rig_help)
    p.set_defaults(func=cmd_verify)

    p = sub.add_parser("diff", parents=[common], help="what changed between two bundles")
    p.add_argument("a", metavar="A", help=ref_help)
    p.add_argument("b", metavar="B", help=ref_help)
    p.add_argument("--rig", default=DEFAULT_RIG, help=rig_help)
    p.add_argument("--grid", type=int, default=9, help="field points per SLM side (default 9)")
    p.set_defaults(func=cmd_diff)

    p = sub.add_parser(
        "export",
        parents=[common],
        help="verify a bundle and write it to a zip, or as files for other software",
    )
    p.add_argument("path", metavar="PATH", help=ref_help)
    p.add_argument("--zip", dest="zip", metavar="OUT.zip", help="zip to create (--format zip)")
    p.add_argument("--rig", default=DEFAULT_RIG, help=rig_help)
    p.add_argument(
        "--format",
        choices=["zip", "sassi-mat"],
        default="zip",
        help="zip (default): the bundle itself; sassi-mat: calibstack.mat and "
        "reverse_lookup.mat for the SASSI authors' reconstruction code, in --out",
    )
    p.add_argument("--out", metavar="DIR", help="folder for --format sassi-mat")
    p.add_argument(
        "--wavelengths",
        metavar="NM",
        help="sassi-mat bands: 450,532,635, START:STOP:STEP, 'paper' (every 10 nm inside "
        "the bundle's range; 30 bands instead of 68 on sim) or 'bins' (default: the "
        "bundle's bins)",
    )
    p.add_argument(
        "--position-quantum",
        metavar="PX",
        help="sassi-mat: round stored positions to this power of two of a pixel, at most "
        "half of it off (default 1/64, files about 4x smaller); 0 stores them exactly",
    )
    p.add_argument("--quiet", action="store_true", help="no progress bars")
    p.set_defaults(func=cmd_export)

    p = sub.add_parser("import", parents=[common], help="verify and import an exported zip")
    p.add_argument("zip", metavar="ZIP", help="archive made by 'bundle export'")
    p.add_argument("--rig", default=None, help="expected rig (default: the bundle's own)")
    p.set_defaults(func=cmd_import)


# -- list ---------------------------------------------------------------------------------------


def _summary_row(
    folder: Path, rig: str, version: str, latest: str | None
) -> tuple[list[str], str | None]:
    """One row of ``bundle list``, read from the manifest without full verification, and
    why the manifest does not read (None: it does)."""
    from sassi_bench.bundle.integrity import MANIFEST_NAME

    marker = "*" if version == latest else ""
    try:
        manifest = json.loads((folder / version / MANIFEST_NAME).read_text("utf-8"))
        created = str(manifest.get("created", "?"))
        if manifest.get("passed") is True:
            status = "passed"
        elif manifest.get("override") is True:
            status = "FAILED(override)"
        else:
            status = "?"
        parent = str(manifest.get("parent") or "-")
        problem = None
    except (OSError, ValueError, AttributeError) as exc:
        created, status, parent = "?", "UNREADABLE", "?"
        problem = f"{MANIFEST_NAME} {_why(exc)}"
    return [rig, version + marker, created, status, parent], problem


def _why(exc: Exception) -> str:
    if isinstance(exc, FileNotFoundError):
        return "is missing"
    if isinstance(exc, OSError):
        return f"cannot be read ({exc.strerror or exc})"
    return f"is not JSON ({exc})"


def cmd_list(args: argparse.Namespace) -> int:
    """``bundle list``: a table of versions (``*`` marks LATEST), each unreadable manifest
    named with its fix, and a ``LATEST`` that names a missing version warned about."""
    from sassi_bench._shared.tables import text_table
    from sassi_bench.bundle.layout import latest_version, rig_dir, rig_names, versions
    from sassi_bench.paths import data_root

    rigs = [args.rig] if args.rig else rig_names(args.data)
    rows, problems, warnings = [], [], []
    for rig in rigs:
        folder = rig_dir(rig, args.data)
        latest = latest_version(folder)
        for version in versions(folder):
            row, problem = _summary_row(folder, rig, version, latest)
            rows.append(row)
            if problem is not None:
                problems.append((rig, version, problem))
        if (warning := latest_problem(folder)) is not None:
            warnings.append(warning)
    if not rows:
        where = rig_dir(args.rig, args.data) if args.rig else data_root(args.data)
        print(f"no calibration bundles under {where}")
        return 0
    print(text_table(["RIG", "VERSION", "CREATED", "STATUS", "PARENT"], rows))
    print("(* = LATEST)")
    for rig, version, problem in problems:
        print(
            f"UNREADABLE {rig}/{version}: {problem}; no command loads this bundle. Fix: "
            f"restore the folder from a backup or its exported zip (`{program()} bundle "
            f"import ZIP`); `{program()} bundle verify {version} --rig {rig}` checks it"
        )
    for warning in warnings:
        print(f"warning: {warning}")
    return 0


# -- show ---------------------------------------------------------------------------------------


def _range(values: np.ndarray, fmt: str = ".1f") -> str:
    return f"{values.min():{fmt}}-{values.max():{fmt}}"


def offset_text(offset: Mapping[str, Any] | None) -> str:
    """The offset model in words: its method, then its other settings.

    Examples
    --------
    >>> offset_text({"fallback": "block-median spline", "method": "per-pixel mean"})
    'per-pixel mean (fallback: block-median spline)'
    >>> offset_text(None), offset_text({"method": "cubic", "blocks": [8, 12]})
    ('none', 'cubic (blocks: 8, 12)')
    """
    if not offset:
        return "none"

    def value(item: Any) -> str:
        if isinstance(item, Mapping):
            return ", ".join(f"{k} {value(v)}" for k, v in item.items())
        if isinstance(item, (list, tuple)):
            return ", ".join(value(v) for v in item)
        return str(item)

    rest = ", ".join(f"{k}: {value(v)}" for k, v in offset.items() if k != "method")
    method = str(offset.get("method", "offset model"))
    return f"{method} ({rest})" if rest else method


def describe(bundle: CalibrationBundle) -> str:
    """Multi-line human summary of a bundle (what ``bundle show`` prints).

    Examples
    --------
    Not run here (it runs a command on a rig and its data)::

        print(describe(load(rig="sim")))
    """
    import numpy as np

    from sassi_bench.bundle.quality import format_tolerance, unit_suffix

    m = bundle.manifest
    models = bundle.models
    soft = m["software"]
    git = soft["git_commit"][:12] if soft["git_commit"] else "unknown"
    if soft.get("git_dirty"):
        git += " (uncommitted changes)"
    height, width = bundle.slm_shape
    centres, edges = bundle.wavelengths, bundle.bin_edges
    streak = bundle.streak((width - 1) / 2, (height - 1) / 2)
    spread = float(streak.x_right.max() - streak.x_left.min())
    sigma = bundle.blur_width(centres)
    i_min = int(np.argmin(sigma))
    schema = m["schema_version"]
    if bundle.migrated_from:
        schema += f" (migrated from {bundle.migrated_from})"
    status = "passed" if bundle.passed else "FAILED (published with an override)"
    lines = [
        f"{bundle.rig_name}/{bundle.version}  ({bundle.path})",
        f"  created     {bundle.created}",
        f"  status      {status}",
        f"  parent      {bundle.parent or 'none'}",
        f"  schema      {m['schema']} {schema}",
        f"  software    {soft['name']} {soft['version']}, git {git}",
        f"  rig         {bundle.rig_name}, rig_hash {m['rig_hash'][:12]}...",
        f"  SLM         {width} x {height} px",
        f"  dispersion  glass {models.dispersion.glass}, legendre2d degree "
        f"{models.dispersion.field_degree}; streak at the field centre spans {spread:.1f} px",
        f"  bins        {centres.size} bins, {edges[0]:.1f}-{edges[-1]:.1f} nm, "
        f"width {_range(np.diff(edges), '.2f')} nm, resolution "
        f"{_range(bundle.bin_resolution_nm, '.2f')} nm",
        f"  blur        sigma {sigma[0]:.2f} px at {centres[0]:.0f} nm, min {sigma[i_min]:.2f} px "
        f"at {centres[i_min]:.0f} nm, {sigma[-1]:.2f} px at {centres[-1]:.0f} nm; "
        f"window +/-{models.blur.window_sigmas:g} sigma",
    ]
    if bundle.guide_to_slm is None:
        lines.append("  guide       homography not calibrated")
    else:
        rms = models.guide_info.get("rms_px")
        lines.append(
            "  guide       guide -> SLM homography calibrated"
            + (f" (rms {rms:.3g} px)" if rms is not None else "")
        )
    lines.append(f"  offset      {offset_text(models.offset)}")
    response = bundle.response
    lines.append(
        "  response    none"
        if response is None
        else f"  response    {response.size} bins, {_range(response, '.3g')}"
    )
    lines.append(f"  inputs      {len(m['inputs'])} raw session(s)")
    checks = m["quality"]["checks"]
    passed = sum(1 for c in checks if c["passed"])
    lines.append(f"  quality     {passed}/{len(checks)} checks passed")
    for c in checks:
        comparison, unit = c.get("comparison", "<="), unit_suffix(c["unit"])
        lines.append(
            f"    {'PASS' if c['passed'] else 'FAIL'}  {c['name']}: {c['value']:.4g}{unit} "
            f"(tolerance {comparison} {format_tolerance(c['tolerance'])}{unit})"
        )
    return "\n".join(lines)


def cmd_show(args: argparse.Namespace) -> int:
    """``bundle show``: verify, then summarise one bundle."""
    print(describe(load_bundle_ref(args.version, args.rig, args.data)))
    return 0


# -- verify -------------------------------------------------------------------------------------


def cmd_verify(args: argparse.Namespace) -> int:
    """``bundle verify``: exit 0 with "OK", or 1 naming the failing file and why."""
    from sassi_bench.bundle.archive import verify_zip
    from sassi_bench.bundle.errors import BundleIntegrityError, BundleSchemaError
    from sassi_bench.bundle.integrity import MANIFEST_NAME
    from sassi_bench.bundle.layout import resolve_bundle_ref
    from sassi_bench.bundle.loader import verify

    given = Path(args.path)
    is_zip = given.is_file() and given.name != MANIFEST_NAME
    path = given if is_zip else resolve_bundle_ref(args.path, rig=args.rig, data=args.data)
    try:
        files = verify_zip(path) if is_zip else verify(path)
    except (BundleIntegrityError, BundleSchemaError) as exc:
        failing = getattr(exc, "file", None)
        print(f"FAILED {path}" + (f" ({failing})" if failing else "") + f": {exc}")
        return 1
    print(f"OK {path}: schema and {len(files)} files verified")
    return 0


# -- diff ---------------------------------------------------------------------------------------


def cmd_diff(args: argparse.Namespace) -> int:
    """``bundle diff A B``: what changed from A to B."""
    from sassi_bench.bundle.diff import diff_bundles, format_diff

    a = load_bundle_ref(args.a, args.rig, args.data)
    b = load_bundle_ref(args.b, args.rig, args.data)
    print(format_diff(diff_bundles(a, b, grid=max(2, args.grid))))
    return 0


# -- export / import ----------------------------------------------------------------------------


def cmd_export(args: argparse.Namespace) -> int:
    """``bundle export PATH --zip OUT.zip`` or ``--format sassi-mat --out DIR``."""
    from sassi_bench.bundle.archive import export_zip

    if args.format == "sassi-mat":
        return _export_sassi_mat(load_bundle_ref(args.path, args.rig, args.data), args)
    source = load_bundle_ref(args.path, args.rig, args.data).path
    sassi_only = {
        "--out": args.out,
        "--wavelengths": args.wavelengths,
        "--position-quantum": args.position_quantum,
    }
    for option, value in sassi_only.items():
        if value is not None:
            raise ProcedureError(
                step_error(
                    "bundle export",
                    f"{option} {value} is read only with --format sassi-mat",
                    "add --format sassi-mat, or give --zip OUT.zip for the bundle itself",
                )
            )
    if not args.zip:
        raise ProcedureError(
            step_error("bundle export", "no --zip OUT.zip given", "add --zip OUT.zip")
        )
    out = export_zip(source, args.zip)
    print(f"exported {source} -> {out}")
    return 0


def cmd_import(args: argparse.Namespace) -> int:
    """``bundle import ZIP``: verify and add the bundle under the data root."""
    from sassi_bench.bundle.archive import import_zip

    result = import_zip(args.zip, rig=args.rig, data=args.data)
    if result.created:
        print(f"imported {args.zip} -> {result.path}")
    elif result.repaired:
        print(f"repaired {result.path} from {args.zip}: replaced {len(result.repaired)} damaged "
              f"file(s): {', '.join(result.repaired)}; it verifies now")  # fmt: skip
    else:
        print(f"already present and verified: {result.path}")
    return 0


def parse_wavelengths(text: str | None) -> np.ndarray | str | None:
    """``"450,532,635"`` or ``"START:STOP:STEP"`` (STOP included when on the grid) in nm,
    or the name of a preset (returned as it is; the export resolves it for the bundle).

    Examples
    --------
    >>> parse_wavelengths("400:700:100").tolist(), parse_wavelengths("450, 532").tolist()
    ([400.0, 500.0, 600.0, 700.0], [450.0, 532.0])
    >>> parse_wavelengths("paper")
    'paper'
    """
    import numpy as np

    if text is None:
        return None
    if text.strip() and text.strip()[0].isalpha():
        return text.strip()
    try:
        if ":" in text:
            start, stop, step = (float(p) for p in text.split(":"))
            if step <= 0:
                raise ValueError
            return np.arange(start, stop + step / 2, step)
        return np.array([float(p) for p in text.split(",")])
    except ValueError:
        raise ProcedureError(
            step_error(
                "bundle export",
                f"--wavelengths {text!r} is not a list of nm",
                "pass e.g. 450,532,635, 400:700:5 or paper",
            )
        ) from None


def parse_quantum(text: str | None) -> float:
    """``"1/64"``, ``"0.015625"`` or ``"0"`` as px (None: the export's default).

    Parameters
    ----------
    text
        ``--position-quantum`` as typed, or None.

    Returns
    -------
    float
        The quantum in camera/SLM pixels (0: exact positions).

    Raises
    ------
    ProcedureError
        If the text is not a number or a fraction.

    Examples
    --------
    >>> parse_quantum("1/64"), parse_quantum("0"), parse_quantum(None)
    (0.015625, 0.0, 0.015625)
    """
    from sassi_bench.export.sassi_mat import DEFAULT_QUANTUM_PX

    if text is None:
        return DEFAULT_QUANTUM_PX
    try:
        number, _, denominator = text.partition("/")
        return float(number) / (float(denominator) if denominator else 1.0)
    except (ValueError, ZeroDivisionError):
        raise ProcedureError(
            step_error(
                "bundle export",
                f"--position-quantum {text!r} is not a number of pixels",
                "pass e.g. 1/64, 1/256 or 0 (exact)",
            )
        ) from None


def _export_sassi_mat(bundle: CalibrationBundle, args: argparse.Namespace) -> int:
    """``bundle export ... --format sassi-mat --out DIR``: write the two calibration files."""
    from sassi_bench.export.sassi_mat import export_sassi_mat

    if not args.out:
        raise ProcedureError(
            step_error("bundle export", "--format sassi-mat needs --out DIR", "add --out DIR")
        )
    done = export_sassi_mat(
        bundle, args.out, wavelengths=parse_wavelengths(args.wavelengths),
        position_quantum_px=parse_quantum(args.position_quantum), progress=not args.quiet,
    )  # fmt: skip
    lam = done.wavelengths
    quantum = done.position_quantum_px
    print(
        f"exported {bundle.rig_name}/{bundle.version} for the SASSI reconstruction code: "
        f"{lam.size} bands {lam[0]:.1f}-{lam[-1]:.1f} nm, camera {done.camera_shape}, "
        f"SLM {done.slm_shape}, {done.seconds:.1f} s"
    )
    print("  " + (f"positions rounded to {quantum:g} px" if quantum else "positions exact"))
    for name, size in done.sizes.items():
        print(f"  {done.folder / name}  ({size / 1e6:.1f} MB)")
    if not bundle.passed:
        print("  note: this bundle FAILED its quality checks (published with an override)")
    print(f"next: read {done.folder / 'README.txt'}, copy both .mat files to <root>/calibration/")
    print(f"      and export a capture with: {program()} snapshot export --format sassi-mat ...")
    return 0
