"""``sassi-bench scan``: a Nyquist pinhole scan of a scene into a reference cube."""

from __future__ import annotations

import argparse
import shlex
from pathlib import Path

from sassi_bench.commands.options import (
    add_bundle_options,
    add_data_option,
    add_rig_option,
    bundle_from_args,
    check_output_file,
    new_session,
    program,
)

__all__ = ["register"]


def _scan(args: argparse.Namespace) -> int:
    from sassi_bench.acquire.plan_geometry import scan_pitch
    from sassi_bench.rig import open_rig
    from sassi_bench.spectra.cube_io import units_label, write_envi, write_netcdf
    from sassi_bench.workflows.scan import check_scan, run_scan

    rig = open_rig(args.rig)
    roi = tuple(args.roi) if args.roi else None
    pitch = scan_pitch(rig.description, args.pitch)
    check_scan(rig, args.scene, args.light, pitch, roi)
    check_output_file("scan", args.out, "--out")
    if args.envi:
        check_output_file("scan", args.envi, "--envi", suffixes=(".hdr", ".img"))
    bundle = bundle_from_args(args, rig.description.name, step="scan", wants=("response",))
    new_session(args, "session", f"scan-{args.scene}")
    run = run_scan(
        rig, bundle, scene=args.scene, light=args.light, pitch=pitch, roi=roi,
        session_id=args.session, data=args.data, progress=not args.quiet,
    )  # fmt: skip
    ds = run.dataset()
    out = write_netcdf(ds, args.out)
    print(f"cube {ds['radiance'].shape} ({units_label(ds['radiance'])}) -> {out}")
    if run.scan.band_noise_psnr_db is not None:
        print(f"per-band PSNR against the cube's own noise -> {_band_psnr_png(run, out)}")
    if args.envi:
        print(f"ENVI -> {write_envi(ds, args.envi)}")
    bad = int((run.scan.quality != 0).sum())
    print(f"flagged pixels: {bad}; problems: {len(run.scan.problems)}")
    for line in run.scan.problems[:10]:
        print(f"  {line}")
    print(next_step(args, out))
    return 0


def next_step(args: argparse.Namespace, out: Path) -> str:
    """The command that scores SASSI snapshots of the scanned scene against this cube.

    Examples
    --------
    >>> args = argparse.Namespace(rig="sim", scene="natural", data=None, bundle=None,
    ...                           bundle_rig=None)
    >>> next_step(args, Path("cube.nc")).split(" --")  # doctest: +NORMALIZE_WHITESPACE
    ['next: score snapshots against this cube: sassi-bench validate snapshot', 'rig sim',
     'scene natural', 'scan cube.nc', 'out snapshot-report']
    """
    options = {"--rig": args.rig, "--scene": args.scene, "--scan": out, "--out": "snapshot-report"}
    options.update({"--data": args.data, "--bundle": args.bundle, "--bundle-rig": args.bundle_rig})
    argv = [str(part) for option, value in options.items() if value is not None
            for part in (option, value)]  # fmt: skip
    return f"next: score snapshots against this cube: {program()} validate snapshot " + (
        shlex.join(argv)
    )


def _band_psnr_png(run, out):
    """Draw the cube's per-band PSNR against its own noise beside the NetCDF; print it."""
    import numpy as np

    from sassi_bench._shared.atomic import atomic_write_bytes
    from sassi_bench.plots.png import figure_png
    from sassi_bench.plots.scan import band_psnr_figure

    scan = run.scan
    lam, band = scan.wavelengths_nm, scan.band_noise_psnr_db
    label = "against the cube's own noise (the deblur's bias is not in it)"
    light = np.nanmean(scan.cube, axis=(0, 1))
    fig, _ = band_psnr_figure(lam, {label: band}, light=light)
    path = out.with_name(out.stem + "-band-psnr.png")
    atomic_write_bytes(path, figure_png(fig), overwrite=True)
    mid, red = (lam > 500) & (lam < 600), lam > 650
    print(
        f"per-band PSNR (noise only): {np.mean(band[mid]):.1f} dB at 500-600 nm, "
        f"{np.mean(band[red]):.1f} dB beyond 650 nm; the deblur's {scan.deblur.parameter} "
        f"{scan.deblur.value:.3g}, chosen by the {scan.deblur.rule} rule"
    )
    return path


def register(sub: argparse._SubParsersAction) -> None:
    """Add ``scan`` to the top-level parser."""
    scan = sub.add_parser("scan", help="Nyquist pinhole scan of a scene into a reference cube")
    add_rig_option(scan)
    add_bundle_options(scan)
    add_data_option(scan)
    scan.add_argument("--session", help="session id; an existing one resumes its capture")
    scan.add_argument("--quiet", action="store_true", help="no progress bars")
    scan.add_argument("--scene", default="colorchecker", help="scene (default: colorchecker)")
    scan.add_argument("--light", default="led", help="light (default: led)")
    scan.add_argument(
        "--pitch", type=int, nargs=2, default=None, metavar=("PX", "PY"),
        help="pinhole pitch, SLM px (default: from the rig's optics, the streaks apart)",
    )  # fmt: skip
    scan.add_argument("--roi", type=int, nargs=4, metavar=("ROW0", "COL0", "ROW1", "COL1"))
    scan.add_argument("--out", required=True, help="NetCDF file to write")
    scan.add_argument("--envi", help="also export ENVI (.hdr/.img) at this path")
    scan.set_defaults(func=_scan, resume_options=(("session", "--session"),), drives_rig=True)
