"""What limits a scan's red end: per-band PSNR against the bench's truth, and its bounds.

On the virtual bench, for a ColorChecker pinhole scan taken with a bundle (a chain's
``<session>-macbeth``):

1. the scan as assembled (the deblur's own choice), and with the best strength for
   every band apart (the bound of its prior);
2. the same plan captured again with photon and read noise off (the sensor's rounding
   kept), assembled alike: what noise costs;
3. noise-free frames of a subset of pinhole offsets at a 15-row pitch (no streaks
   stacked, so no row unmixing): what the row unmixing of stacked pinholes costs.

Prints the mean per-band PSNR at 500-600 nm and beyond 650 nm of each, and the curve.
The truth and the noise-free captures are the bench's: this is a benchmark, not a
procedure. About two minutes of CPU on ``sim``.

Run: ``python benchmarks/red_end_bound.py --data DIR --session full-...-macbeth``
(``--data`` the chain's staging folder holding the session, ``--bundle-data`` the data
root holding the bundle).
"""

from __future__ import annotations

import argparse
import tempfile

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


def _noise_free(self, electron_rate, exposure_s, rng):
    """The sensor's exposure without photon and read noise."""
    mean = (np.asarray(electron_rate, np.float64) + self.dark_current_e_per_s) * exposure_s
    mean = np.minimum(np.maximum(mean, 0.0), self.full_well_e)
    adu = np.rint(mean / self.gain_e_per_adu + self.dark_offset_adu)
    return np.clip(adu, 0, self.max_adu).astype(self.dtype)


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
        "--row-mixture", action="store_true", help="assemble with the mixed-blur row unmixing"
    )
    args = parser.parse_args()
    rig = open_rig(args.rig)
    bundle = load(rig=rig.description.name, data=args.bundle_data or args.data)
    wl = bundle.wavelengths
    mid, red = (wl > 500) & (wl < 600), wl > 650
    source = Session.open(args.session, data=args.data)
    scene, light = source.plan.parameters["scene"], source.plan.parameters["light"]
    expected = truth(rig).binned_cube(bundle.bin_edges, light, scene)
    model = StreakForwardModel.from_bundle(bundle)
    rows = {}
    scan = assemble_scan(
        source, bundle, keep_raw=True, progress=False, row_mixture=args.row_mixture
    )
    rows["as captured"] = band_psnr(scan.cube, expected, scan.quality == 0, wl)
    rows["as captured, best strength per band"] = best_per_band(scan, model, expected, wl)
    sensor.SensorModel.expose = _noise_free
    exposure = source.plan.steps[1].exposure_s
    with tempfile.TemporaryDirectory(prefix="red-end-") as tmp:
        clean_rig = open_rig(args.rig)
        clean_rig.set_scene(scene)
        clean = Session.create(clean_rig.description, source.plan, session_id="clean", data=tmp)
        run_plan(clean_rig, source.plan, clean, progress=False)
        scan = assemble_scan(
            clean, bundle, keep_raw=True, progress=False, row_mixture=args.row_mixture
        )
        rows["noise-free"] = band_psnr(scan.cube, expected, scan.quality == 0, wl)
        rows["noise-free, best strength per band"] = best_per_band(scan, model, expected, wl)
        steps = [Step("spectral", light, exposure, {"kind": "blank"}, {"role": "closed"})]
        for oy in (0, 5, 10):
            for ox in range(0, 100, 10):
                pattern = {"kind": "pinholes", "pitch": [100, 15], "offset": [ox, oy]}
                steps.append(
                    Step("spectral", light, exposure, pattern, {"role": "pinholes", "ox": ox})
                )
        plan = Plan("pinhole-scan", tuple(steps), {"pitch": [100, 15], "scene": scene})
        sparse = Session.create(clean_rig.description, plan, session_id="sparse", data=tmp)
        run_plan(clean_rig, plan, sparse, progress=False)
        scan = assemble_scan(
            sparse, bundle, keep_raw=True, progress=False, row_mixture=args.row_mixture
        )
        rows["noise-free, 15-row pitch"] = band_psnr(scan.cube, expected, scan.quality == 0, wl)
        rows["noise-free, 15-row pitch, best per band"] = best_per_band(scan, model, expected, wl)
    print("| | 500-600 nm | > 650 nm |\n| --- | --- | --- |")
    for name, band in rows.items():
        print(f"| {name} | {band[mid].mean():.1f} dB | {band[red].mean():.1f} dB |")
    print("\nnm " + " ".join(f"{w:6.1f}" for w in wl[::4]))
    for name, band in rows.items():
        print(f"{name}: " + " ".join(f"{v:6.1f}" for v in band[::4]))


if __name__ == "__main__":
    main()
