"""Command line of the exports: ``sassi-bench snapshot export`` and the ``sassi-mat``
format of ``sassi-bench bundle export``.

Examples
--------
>>> from sassi_bench.cli import main
>>> main(["bundle", "export", "latest", "--format", "sassi-mat",
...       "--out", "for_sassi"])  # doctest: +SKIP
>>> main(["snapshot", "export", "--session", "snap-1", "--step", "0", "--guide-step", "1",
...       "--out", "exp1"])  # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.workflows import snapshot_cli

__all__ = ["parse_tags", "parse_wavelengths", "register", "run_bundle_export"]


def parse_wavelengths(text: str | None) -> np.ndarray | None:
    """``"450,532,635"`` or ``"START:STOP:STEP"`` (STOP included when on the grid) in nm.

    Examples
    --------
    >>> parse_wavelengths("400:700:100").tolist(), parse_wavelengths("450, 532").tolist()
    ([400.0, 500.0, 600.0, 700.0], [450.0, 532.0])
    """
    if text is None:
        return None
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
                "pass e.g. 450,532,635 or 400:700:5",
            )
        ) from None


def parse_tags(pairs: list[str] | None) -> dict[str, Any]:
    """``["role=snapshot", "index=3"]`` -> ``{"role": "snapshot", "index": 3}`` (values
    that read as JSON are JSON, others strings).

    Examples
    --------
    >>> parse_tags(["role=snapshot", "index=3", "on=true"])
    {'role': 'snapshot', 'index': 3, 'on': True}
    """
    tags: dict[str, Any] = {}
    for pair in pairs or []:
        key, sep, value = pair.partition("=")
        if not sep or not key:
            raise ProcedureError(
                step_error("snapshot export", f"tag {pair!r} is not KEY=VALUE", "e.g. role=snap")
            )
        try:
            tags[key] = json.loads(value)
        except ValueError:
            tags[key] = value
    return tags


def run_bundle_export(bundle, args: argparse.Namespace) -> int:
    """``bundle export ... --format sassi-mat --out DIR``: write the two calibration files."""
    from sassi_bench.export.sassi_mat import export_sassi_mat

    if not args.out:
        raise ProcedureError(
            step_error("bundle export", "--format sassi-mat needs --out DIR", "add --out DIR")
        )
    done = export_sassi_mat(
        bundle, args.out, wavelengths=parse_wavelengths(args.wavelengths), progress=not args.quiet
    )
    lam = done.wavelengths
    print(
        f"exported {bundle.rig_name}/{bundle.version} for the SASSI reconstruction code: "
        f"{lam.size} bands {lam[0]:.1f}-{lam[-1]:.1f} nm, camera {done.camera_shape}, "
        f"SLM {done.slm_shape}, {done.seconds:.1f} s"
    )
    for name, size in done.sizes.items():
        print(f"  {done.folder / name}  ({size / 1e6:.1f} MB)")
    if not bundle.passed:
        print("  note: this bundle FAILED its quality checks (published with an override)")
    print(f"next: read {done.folder / 'README.txt'}, copy both .mat files to <root>/calibration/")
    print("      and export a capture with: sassi-bench snapshot export --format sassi-mat ...")
    return 0


def _load_bundle(args: argparse.Namespace, session_rig: str):
    from sassi_bench.bundle import load
    from sassi_bench.bundle.layout import resolve_bundle_ref

    return load(resolve_bundle_ref(args.bundle, rig=args.rig or session_rig, data=args.data))


def _snapshot_export(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.session import Session
    from sassi_bench.export.adaptive_cassi import export_adaptive_cassi, select_steps

    if Path(args.out).exists() and not Path(args.out).is_dir():
        raise ProcedureError(
            step_error("snapshot export", f"--out {args.out} is a file", "give a folder")
        )
    session = Session.open(args.session, data=args.data)
    guide_session = (
        session if args.guide_session is None else Session.open(args.guide_session, data=args.data)
    )
    spectral = select_steps(session, "spectral", step=args.step, tags=parse_tags(args.tag))
    if len(spectral) > 1:
        raise ProcedureError(
            step_error(
                "snapshot export",
                f"the tags {parse_tags(args.tag)} match {len(spectral)} spectral frames "
                f"({spectral[:8]})",
                "pass --step N or tags that match one frame",
            )
        )
    if args.guide_step is None and not args.guide_tag:
        captured = [
            i for i in sorted(guide_session.completed)
            if guide_session.plan.steps[i].camera == "guide"
        ]  # fmt: skip
        if len(captured) != 1:
            raise ProcedureError(
                step_error(
                    "snapshot export",
                    f"session {guide_session.id!r} has {len(captured)} guide frames "
                    f"({captured[:8]}), so which to pair is ambiguous",
                    "pass --guide-step N (repeatable) or --guide-tag KEY=VALUE",
                )
            )
        guides = captured
    else:
        guides = []
        for i in args.guide_step or [None]:
            guides += select_steps(guide_session, "guide", step=i, tags=parse_tags(args.guide_tag))
    darks = (
        select_steps(guide_session, "guide", tags=parse_tags(args.guide_dark_tag))
        if args.guide_dark_tag
        else []
    )
    bundle = _load_bundle(args, str(session.rig.get("name", "sim")))
    done = export_adaptive_cassi(
        bundle, session, spectral[0], args.out, guide_steps=sorted(set(guides)),
        guide_session=guide_session, guide_dark_steps=darks, limits=args.limits,
    )  # fmt: skip
    h1, h2, w1, w2 = done.limits
    print(
        f"exported session {session.id!r} step {spectral[0]} ({done.open_pixels} open SLM "
        f"pixels), guide steps {sorted(set(guides))}"
        + (f" minus dark {darks}" if darks else "")
        + f", bundle {bundle.rig_name}/{bundle.version}, limits [{h1} {h2} {w1} {w2}]"
    )
    print(f"  {done.path}")
    for note in done.notes:
        print(f"  note: {note}")
    print(
        "next: with the calibration files from 'sassi-bench bundle export --format sassi-mat' "
        "in <root>/calibration/, run cassi.py with expname set to this folder's name"
    )
    return 0


def register(subparsers: Any) -> None:
    """Add the ``snapshot`` command group (``take``, ``reconstruct``, ``export``).

    Examples
    --------
    >>> parser = argparse.ArgumentParser(prog="sassi-bench")
    >>> register(parser.add_subparsers())
    >>> args = parser.parse_args(["snapshot", "export", "--session", "s", "--step", "0",
    ...                           "--out", "x"])
    >>> args.func.__name__, args.format, args.limits
    ('_snapshot_export', 'sassi-mat', None)
    """
    parser = subparsers.add_parser(
        "snapshot",
        help="take and reconstruct SASSI snapshots, or export them for other packages",
        description="Work with SASSI snapshots (frames of a raw session and their masks).",
    )
    sub = parser.add_subparsers(dest="snapshot_command", metavar="SUBCOMMAND", required=True)
    snapshot_cli.register(sub)
    p = sub.add_parser(
        "export",
        help="a spectral frame, its SLM mask and a guide frame as adaptive_cassi.mat",
        description=(
            "Write OUT/adaptive_cassi.mat (lcos_mask, cassi_img, guide_img_rec, limits) for "
            "the SASSI authors' reconstruction code, from one spectral frame of a raw "
            "session, the SLM pattern it was captured with and the guide frame(s) to pair."
        ),
    )
    p.add_argument("--format", choices=["sassi-mat"], default="sassi-mat", help="(sassi-mat)")
    p.add_argument("--session", required=True, help="session id or folder of the spectral frame")
    which = p.add_mutually_exclusive_group(required=True)
    which.add_argument("--step", type=int, help="plan step index of the spectral frame")
    which.add_argument(
        "--tag", action="append", metavar="KEY=VALUE", help="tags of the spectral frame"
    )
    p.add_argument(
        "--guide-step", type=int, action="append", metavar="N",
        help="guide frame(s) to pair, averaged (default: the session's only guide frame)",
    )  # fmt: skip
    p.add_argument("--guide-tag", action="append", metavar="KEY=VALUE", help="guide frames by tag")
    p.add_argument(
        "--guide-dark-tag", action="append", metavar="KEY=VALUE",
        help="dark guide frames (light off) to subtract, by tag",
    )  # fmt: skip
    p.add_argument("--guide-session", help="session of the guide frames (default: --session)")
    p.add_argument(
        "--bundle", default="latest",
        help="bundle version of the session's rig (v0003, 3, latest) or folder (default latest)",
    )  # fmt: skip
    p.add_argument("--rig", help="rig of --bundle (default: the session's rig)")
    p.add_argument(
        "--limits", type=int, nargs=4, metavar=("H1", "H2", "W1", "W2"),
        help="SLM crop as Python slice bounds (default: the whole SLM, which cassi.py needs)",
    )  # fmt: skip
    p.add_argument("--out", required=True, help="folder to write adaptive_cassi.mat into")
    p.add_argument("--data", help="data root (default: $SASSI_BENCH_DATA or ./calib_data)")
    p.set_defaults(func=_snapshot_export)
