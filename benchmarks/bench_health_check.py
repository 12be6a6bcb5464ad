"""Calibration health check: false alarms, drift detection and time, against the truth.

Calibrates a rig's spectral stage once (or uses the latest bundle already in ``--data``),
then runs ``--repeats`` health checks on the bench as calibrated and as many on the same
bench opened ``--hours`` later with its relay drifting ``--drift-px`` camera px along the
dispersion over that time (``nuisance.drift``; the rig hash, and so the bundle, is the
same). Prints how many checks flag each bench, the measured shift against the true
drift, and the check's capture and processing times.

Run: ``python benchmarks/bench_health_check.py [--rig sim] [--data DIR] [--repeats 20]``
"""

from __future__ import annotations

import argparse
import tempfile

import numpy as np

from sassi_bench import open_rig
from sassi_bench.bundle import load
from sassi_bench.bundle.errors import BundleError
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.health_check import run_health_check
from sassi_bench.workflows.spectral import run_spectral_calibration


def _bundle(rig, data):
    try:
        return load(rig=rig.description.name, data=data)
    except BundleError:  # no bundle yet: calibrate one
        run_spectral_calibration(
            rig, load_procedure("spectral_calibration"), data=data, progress=False
        )
        return load(rig=rig.description.name, data=data)


def _checks(rig, bundle, repeats, data):
    proc = load_procedure("health_check")
    return [run_health_check(rig, bundle, proc, data=data) for _ in range(repeats)]


def _print(name, checks, true_px):
    mean = np.array([c.field.mean_px for c in checks])
    largest = np.array([c.field.max_px for c in checks])
    flagged = sum(not c.holds for c in checks)
    capture = [c.capture_s for c in checks]
    processing = [c.processing_s for c in checks]
    print(
        f"{name}: flagged {flagged}/{len(checks)}; mean shift {mean.mean():+.4f} +- "
        f"{mean.std():.4f} px (true {true_px:+.4f}); largest {largest.min():.4f}-"
        f"{largest.max():.4f} px; capture {min(capture):.2f}-{max(capture):.2f} s, "
        f"processing {min(processing):.2f}-{max(processing):.2f} s"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", default="sim")
    parser.add_argument("--data", default=None, help="data root (default: a new temporary one)")
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--drift-px", type=float, default=0.2)
    parser.add_argument("--hours", type=float, default=6.0)
    args = parser.parse_args()
    data = args.data or tempfile.mkdtemp(prefix="bench-health-")
    rig = open_rig(args.rig)
    bundle = _bundle(rig, data)
    _print("still bench", _checks(rig, bundle, args.repeats, data), 0.0)
    drifting = load_rig_description(args.rig).to_dict()
    rate = args.drift_px / args.hours
    drifting["nuisance"] = {"drift": {"start_h": args.hours, "relay_offset_px_per_h": [rate, 0.0]}}
    later = open_rig(rig_description_from_dict(drifting))
    checks = _checks(later, bundle, args.repeats, data)
    _print(f"{args.hours:g} h later", checks, truth(later).drift_at(args.hours).offset_px[0])


if __name__ == "__main__":
    main()
