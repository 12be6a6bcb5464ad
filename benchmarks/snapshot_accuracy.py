"""Snapshot accuracy against the pinhole scan, per rig: the numbers the README quotes.

For each rig, calibrates the whole chain (``sassi-bench calibrate``; or reuses the latest
bundle of a data root given with ``--data``), then runs the snapshot validation
(``sassi-bench validate snapshot``) on the natural scene with the photon-starved snapshot:
a 100 x 5 pinhole scan of the whole SLM as the reference, the adaptive snapshot
reconstructed by rank-1 and by the guided filter. Prints a Markdown table, one column per
rig. The reconstruction never sees the bench's truth; the scan is the reference.

Writes each rig's column, with the date, the machine and the command, into
``docs/_data/snapshot_accuracy.json`` (the table the accuracy page quotes) unless
``--no-update``.

Run: ``python benchmarks/snapshot_accuracy.py [--rigs sim sim-prototype] [--data DIR]
[--row-pitch N] [--scan CUBE.nc]``. With ``--data`` the scan is kept there as
``scan-<rig>-natural.nc``, for ``--scan`` in later runs. sim takes about 6 minutes on two
quiet cores; sim-prototype about 40 minutes (most of it the calibration and the 500-frame
scan of a 2048 x 2048 camera) and about 10 GB of memory.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from sassi_bench import open_rig
from sassi_bench.bundle import load
from sassi_bench.bundle.errors import BundleError
from sassi_bench.procedure import load_procedure
from sassi_bench.workflows.full import run_full_calibration
from sassi_bench.workflows.snapshot_validation import run_snapshot


def _bundle(rig, data: Path):
    """The latest bundle of the rig under ``data``, calibrating first if there is none."""
    try:
        return load(rig=rig.description.name, data=data)
    except BundleError:  # none published yet: calibrate (minutes to half an hour)
        procedure = load_procedure("full_calibration")
        result = run_full_calibration(
            rig, procedure, session_id=f"accuracy-{rig.description.name}", data=data,
            progress=True, allow_failed=True,
        )  # fmt: skip
        return load(result.bundle_path)


def measure(
    rig_name: str, data: Path, row_pitch: int | None, scan: str | None = None
) -> dict[str, str]:
    """Calibrate (or reuse) and validate snapshots on one rig (against ``scan``, a scan
    cube taken before, when given)."""
    rig = open_rig(rig_name)
    bundle = _bundle(rig, data)
    procedure = load_procedure("snapshot_validation")
    procedure["snapshot"]["compare_masks"] = []  # the adaptive mask and its low-light twin
    if row_pitch is not None:  # 0: the rule whose footprints never overlap
        procedure["snapshot"]["row_pitch_px"] = row_pitch or None
    start = time.perf_counter()
    result = run_snapshot(
        rig, bundle, procedure, scene="natural", scan_path=scan, low_light=True, data=data,
        session_id=f"accuracy-{int(time.time())}", progress=True,
    )  # fmt: skip
    elapsed = time.perf_counter() - start
    main, low = result.runs["adaptive"], result.runs["adaptive_low_light"]
    r, g = main.scores["rank1"], main.scores["guided"]
    lr, lg = low.scores["rank1"], low.scores["guided"]
    h, w = bundle.slm_shape
    samples = main.error_split["samples_psnr_db"]
    if result.scan_dataset is not None:  # keep the scan for later runs (--scan)
        from sassi_bench.spectra.cube_io import write_netcdf

        write_netcdf(result.scan_dataset, data / f"scan-{rig_name}-natural.nc", overwrite=True)
    return {
        "SLM (px)": f"{w} x {h}",
        "bundle bins": f"{bundle.wavelengths.size}",
        "row pitch / uniform step (px)": f"{result.spacing['pitch']} / "
        f"{result.spacing['uniform_step']}",
        "open pixels (SLM px per open px)": f"{int(main.mask.sum())} "
        f"({h * w / max(int(main.mask.sum()), 1):.0f})",
        "rank-1 PSNR raw / affine": f"{r.psnr_db:.2f} / {r.psnr_affine_db:.2f} dB",
        "guided PSNR raw / affine": f"{g.psnr_db:.2f} / {g.psnr_affine_db:.2f} dB",
        "rank-1 SSIM / spectral angle": f"{r.ssim:.3f} / {r.spectral_angle_deg:.2f} deg",
        "spectra at the open pixels against the scan": f"{samples:.2f} dB",
        "low light (0.02x): rank-1 / guided affine": f"{lr.psnr_affine_db:.2f} / "
        f"{lg.psnr_affine_db:.2f} dB",
        "all checks pass": "yes" if result.passed else "no",
        "validation time (scan included)": f"{elapsed / 60:.1f} min",
        "scan pixels scored": f"{int(np.count_nonzero(result.valid))}",
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rigs", nargs="+", default=["sim", "sim-prototype"])
    parser.add_argument("--data", help="data root with calibrated bundles (default: a temp dir)")
    parser.add_argument(
        "--row-pitch", type=int,
        help="the mask rule's row pitch (default: the procedure's; 0: footprints never overlap)",
    )  # fmt: skip
    parser.add_argument("--scan", help="a scan cube (NetCDF) of the natural scene, one rig only")
    parser.add_argument(
        "--no-update",
        action="store_true",
        help="print only: leave docs/_data/snapshot_accuracy.json",
    )
    args = parser.parse_args()
    if args.scan and len(args.rigs) != 1:
        parser.error("--scan scores one rig: give one --rigs")
    if args.scan and not args.data:
        parser.error("--scan needs the --data root of the bundle the scan was assembled with")
    columns = {}
    for rig_name in args.rigs:
        if args.data:
            columns[rig_name] = measure(rig_name, Path(args.data), args.row_pitch, args.scan)
        else:
            with tempfile.TemporaryDirectory(prefix="snapshot-accuracy-") as tmp:
                columns[rig_name] = measure(rig_name, Path(tmp), args.row_pitch)
    rows = next(iter(columns.values())).keys()
    print("| | " + " | ".join(f"`{name}`" for name in columns) + " |")
    print("| --- |" + " --- |" * len(columns))
    for row in rows:
        print(f"| {row} | " + " | ".join(col[row] for col in columns.values()) + " |")
    if not args.no_update and args.row_pitch is None:  # the procedure's own setting only
        from figures import update_columns

        path = update_columns(
            "snapshot_accuracy",
            "Snapshots of the natural scene against a pinhole scan, with the whole chain's bundle",
            list(rows),
            [{"key": name, "values": dict(col)} for name, col in columns.items()],
            code_keys=True,
        )
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
