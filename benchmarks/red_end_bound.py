"""What limits a scan's red end: per-band PSNR against the bench's truth, and its bounds.

On the virtual bench, for a ColorChecker pinhole scan taken with a bundle (a chain's
``<session>-macbeth``):

1. the scan as assembled (the deblur's own choice), and with the best strength for
   every band apart (the bound of its prior);
2. the same plan captured again with photon and read noise off (the sensor's rounding
   kept), assembled alike: what noise costs;
3. frames of a subset of pinhole offsets at a 15-row pitch (no streaks stacked, so no
   row unmixing), with noise and noise-free: what the row unmixing of stacked pinholes
   costs, and the deblur's own part at the red end (the noisy row is the one a
   regulariser is judged by: a weaker one amplifies the noise).

Prints the mean per-band PSNR at 500-600 nm and beyond 650 nm of each, and the curve.
The truth and the noise-free captures are the bench's: this is a benchmark, not a
procedure. About two minutes of CPU on ``sim``.

Run: ``python benchmarks/red_end_bound.py --data DIR --session full-...-macbeth``
(``--data`` the chain's staging folder holding the session, ``--bundle-data`` the data
root holding the bundle; ``--rows captured noise-free pitch`` any of the three groups).
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

from sassi_bench import open_rig
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.optics import sensor
from sassi_bench.rig.sim import truth
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.priors import RelativeSmoothnessPrior
from sassi_bench.spectra.scan import assemble_scan

STRENGTHS = (0.25, 0.5, 1.0, 2.0, 4.0, 8.0)

#: Groups of rows ``--rows`` can pick.
GROUPS = ("captured", "noise-free", "pitch")


def _noise_free(self, electron_rate, exposure_s, rng):
    """The sensor's exposure (:meth:`SensorModel.expose`) without photon and read noise."""
    mean = (np.asarray(electron_rate, np.float64) + self.dark_current_e_per_s) * exposure_s
    mean = np.minimum(np.maximum(mean, 0.0), self.full_well_e)
    adu = np.rint(mean / self.gain_e_per_adu + self.dark_offset_adu)
    return np.clip(adu, 0, self.max_adu).astype(self.dtype)


def _capture(rig_name, scene, plan, session_id, data, *, noise=True):
    """``plan`` captured on a fresh bench showing ``scene``, with or without noise."""
    expose = sensor.SensorModel.expose
    if not noise:
        sensor.SensorModel.expose = _noise_free
    try:
        rig = open_rig(rig_name)
        rig.set_scene(scene)
        session = Session.create(rig.description, plan, session_id=session_id, data=data)
        run_plan(rig, plan, session, progress=False)
    finally:
        sensor.SensorModel.expose = expose
    return session


def sparse_plan(light, exposure, scene) -> Plan:
    """Pinholes 15 rows apart at 30 offsets: no streak stacked on another."""
    steps = [Step("spectral", light, exposure, {"kind": "blank"}, {"role": "closed"})]
    for oy in (0, 5, 10):
        for ox in range(0, 100, 10):
            pattern = {"kind": "pinholes", "pitch": [100, 15], "offset": [ox, oy]}
            steps.append(Step("spectral", light, exposure, pattern, {"role": "pinholes", "ox": ox}))
    return Plan("pinhole-scan", tuple(steps), {"pitch": [100, 15], "scene": scene})


def band_psnr(cube, expected, good, wl):
    """Per-band PSNR after one gain (as ``accuracy_table._chart_scan_scores``)."""
    a, b = cube[good].astype(np.float64), expected[good]
    gain = (a * b).sum() / (b * b).sum()
    peak = (gain * b).max()
    return 10 * np.log10(peak**2 / ((a - gain * b) ** 2).mean(axis=0))


def best_per_band(scan, model, expected, wl):
    """Per-band PSNR at the best of :data:`STRENGTHS` for every band apart."""
    good = scan.quality == 0
    rows, cols = np.nonzero(good)
    values = scan.column_sums[rows, cols].astype(np.float64)
    prior = RelativeSmoothnessPrior.of(scan.mean_spectrum)
    bands = []
    for s in STRENGTHS:
        out = SpectralDeblur.from_model(model, prior, strength=s).apply(values, rows, cols)
        cube = np.zeros(scan.cube.shape)
        cube[rows, cols] = out[:, model.core]
        bands.append(band_psnr(cube, expected, good, wl))
    return np.max(bands, axis=0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", default="sim")
    parser.add_argument("--data", required=True, help="folder holding the chart scan session")
    parser.add_argument("--session", required=True, help="the chart scan's session id")
    parser.add_argument("--bundle-data", help="data root of the bundle (default: --data)")
    parser.add_argument(
        "--rows", nargs="+", choices=GROUPS, default=list(GROUPS), help="which rows to measure"
    )
    parser.add_argument(
        "--row-mixture", action="store_true", help="assemble with the mixed-blur row unmixing"
    )
    args = parser.parse_args()
    rig = open_rig(args.rig)
    bundle = load(rig=rig.description.name, data=args.bundle_data or args.data)
    wl = bundle.wavelengths
    mid, orange, red = (wl > 500) & (wl < 600), (wl > 580) & (wl < 640), wl > 650
    source = Session.open(args.session, data=args.data)
    scene, light = source.plan.parameters["scene"], source.plan.parameters["light"]
    expected = truth(rig).binned_cube(bundle.bin_edges, light, scene)
    model = StreakForwardModel.from_bundle(bundle)
    rows, cpu = {}, {}

    def measure(name, session):
        start = time.process_time()
        scan = assemble_scan(
            session, bundle, keep_raw=True, progress=False, row_mixture=args.row_mixture
        )
        cpu[name] = time.process_time() - start
        rows[name] = band_psnr(scan.cube, expected, scan.quality == 0, wl)
        rows[f"{name}, best strength per band"] = best_per_band(scan, model, expected, wl)

    if "captured" in args.rows:
        measure("as captured", source)
    exposure = source.plan.steps[1].exposure_s
    with tempfile.TemporaryDirectory(prefix="red-end-") as tmp:
        if "noise-free" in args.rows:
            clean = _capture(args.rig, scene, source.plan, "clean", tmp, noise=False)
            measure("noise-free", clean)
        if "pitch" in args.rows:
            plan = sparse_plan(light, exposure, scene)
            measure("15-row pitch", _capture(args.rig, scene, plan, "sparse", tmp))
            clean = _capture(args.rig, scene, plan, "sparse-clean", tmp, noise=False)
            measure("noise-free, 15-row pitch", clean)
    print("| | 500-600 nm | 580-640 nm | > 650 nm |\n| --- | --- | --- | --- |")
    for name, band in rows.items():
        means = " | ".join(f"{band[m].mean():.1f} dB" for m in (mid, orange, red))
        print(f"| {name} | {means} |")
    print("\nassembly CPU: " + ", ".join(f"{k} {v:.1f} s" for k, v in cpu.items()))
    print("\nnm " + " ".join(f"{w:6.1f}" for w in wl[::4]))
    for name, band in rows.items():
        print(f"{name}: " + " ".join(f"{v:6.1f}" for v in band[::4]))


if __name__ == "__main__":
    main()
