"""``sassi-bench rig``: show a rig description, check its devices, take snapshots."""

from __future__ import annotations

import argparse
from pathlib import Path

from sassi_bench.commands.options import (
    add_rig_option,
    add_simulate_option,
    check_output_file,
    program,
)

__all__ = ["register"]


def _show(args: argparse.Namespace) -> int:
    import yaml

    from sassi_bench.rig.config import load_rig_description

    if args.figure:
        check_output_file("rig show", args.figure, "--figure")
    desc = load_rig_description(args.rig)
    print(f"# rig {desc.name} ({desc.source}), sha256 {desc.sha256()[:12]}")
    print(yaml.safe_dump(desc.to_dict(), sort_keys=False), end="")
    if desc.design is None:
        if args.figure:
            print("# no figure: the rig has no design: section (see docs/optical_design.md)")
        return 0
    relay = desc.nominal_relay()
    print(
        f"# as designed: {relay.scale:.4f} camera px per SLM px, 400-700 nm over "
        f"{desc.prism.spread_px:.1f} px at the field centre, widest spot "
        + ", ".join(f"{s:.2f} px at {lam:g} nm" for lam, s in desc.blur.sigma_px.items())
    )
    if args.figure:
        from sassi_bench.plots.design import design_figure

        out = Path(args.figure)
        figure = design_figure(relay, desc.nominal_optic(), title=f"{desc.name}: as designed")
        figure.savefig(out, dpi=110)
        print(f"# layout, spots and dispersion: {out}")
    else:
        print(f"# draw it: {program()} rig show --rig {args.rig} --figure {desc.name}.png")
    return 0


def _check(args: argparse.Namespace) -> int:
    import time

    from sassi_bench.rig import check_rig, load_rig_description

    start = time.monotonic()
    desc = load_rig_description(args.rig)
    simulated = " (simulated devices)" if getattr(args, "simulate", False) else ""
    print(f"rig check: {desc.name} ({desc.source}), backend {desc.backend}{simulated}")
    report = check_rig(desc, simulate=getattr(args, "simulate", False))
    for line in report.lines():
        print(line)
    failed = report.failed_devices()
    took = time.monotonic() - start
    rig = args.rig
    if failed:
        print(f"{len(failed)} device(s) need attention: {', '.join(failed)} ({took:.1f} s)")
        print(f"next: fix the FAIL lines, then run {program()} rig check --rig {rig} again")
        if desc.backend == "hardware" and not simulated:
            print(
                f"      to rehearse without the hardware: {program()} rig check --rig {rig} "
                "--simulate"
            )
    else:
        print(f"every device answered ({took:.1f} s)")
        simulate = " --simulate" if simulated else ""
        print(f"next: {program()} align --rig {rig}{simulate} (focus, streak roll, footprint)")
        print(f"      then: {program()} calibrate spectral --rig {rig}{simulate}")
    return 0 if not failed else 1


def _snapshot(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.views import save_views
    from sassi_bench.rig import load_rig_description, open_rig
    from sassi_bench.rig.rig import check_light, check_scene

    desc = load_rig_description(args.rig)
    check_scene(args.scene, step="rig snapshot")
    check_light(args.light, desc.light_names, step="rig snapshot")
    rig = open_rig(desc)
    files = save_views(rig, Path(args.out), scene=args.scene, light=args.light)
    for path in files:
        print(path)
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    """Add the ``rig`` command group to the top-level parser."""
    rig = sub.add_parser("rig", help="inspect a rig and take snapshots")
    rig_sub = rig.add_subparsers(dest="rig_command", metavar="SUBCOMMAND", required=True)
    show = rig_sub.add_parser("show", help="print the validated rig description")
    add_rig_option(show)
    show.add_argument(
        "--figure", help="a design rig: write its layout, spots and dispersion to this PNG"
    )
    show.set_defaults(func=_show)
    check = rig_sub.add_parser(
        "check",
        help="open every device in turn and check it against the rig YAML",
        description="Open every device of the rig in turn (trigger, SLM, cameras, lights) "
        "and report each on one line with the fix when it does not answer; read its "
        "properties against the rig YAML, take one test frame per camera, show one SLM "
        "pattern and count the trigger's pulses. Exit status 1 when a device fails.",
    )
    add_rig_option(check)
    add_simulate_option(check)
    check.set_defaults(func=_check, drives_rig=True)
    snap = rig_sub.add_parser(
        "snapshot", help="save a guide image and spectral frames as PNG and 16-bit TIFF"
    )
    add_rig_option(snap)
    snap.add_argument("--out", required=True, help="output directory")
    snap.add_argument("--scene", default="colorchecker", help="scene (default: colorchecker)")
    snap.add_argument("--light", default="led", help="light (default: led)")
    snap.set_defaults(func=_snapshot, drives_rig=True)
