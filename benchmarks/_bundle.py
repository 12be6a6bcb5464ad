"""The calibration bundle a benchmark needs: a given folder, or a fresh calibration."""

from __future__ import annotations

from sassi_bench.bundle import CalibrationBundle, load
from sassi_bench.procedure import load_procedure
from sassi_bench.rig import Rig
from sassi_bench.workflows.spectral import run_spectral_calibration


def bundle_for(rig: Rig, path: str | None, data: str) -> CalibrationBundle:
    """Load the bundle at ``path``, or spectrally calibrate ``rig`` into ``data`` first."""
    if path:
        return load(path)
    print("calibrating the rig first ...")
    proc = load_procedure("spectral_calibration")
    result = run_spectral_calibration(rig, proc, data=data, progress=False)
    return load(result.bundle_path)
