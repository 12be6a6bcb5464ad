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

Prints the mean per-band PSNR at 500-600 nm, 580-640 nm and beyond 650 nm of each, and
the curve; then, for each assembly, the cube's own noise (its ``band_noise_psnr_db``,
what the scan reports) and the error of each chart patch's mean (the pixels the truth
gives one spectrum, averaged: the systematic part, which no averaging of frames removes),
as per-band PSNR alike.
The truth and the noise-free captures are the bench's: this is a benchmark, not a
procedure. About two minutes of CPU on ``sim``.

Run: ``python benchmarks/red_end_bound.py --data DIR --session full-...-macbeth``
(``--data`` the chain's staging folder holding the session, ``--bundle-data`` the data
root holding the bundle; ``--rows captured noise-free pitch`` any of the three groups;
``--separable`` assembles with the separable row unmixing instead of the scan's default,
the mixed-blur one).
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np
from numpy.typing import NDArray

from sassi_bench import open_rig
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.optics import sensor
from sassi_bench.reduce.scan import assemble_scan
from sassi_bench.rig.sim import truth
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.priors import RelativeSmoothnessPrior

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


def _scaled(cube, expected, good):
    """The good pixels' (N, B) measured and expected spectra, the expected after the one
    gain that fits them best, and the peak of those."""
    a, b = cube[good].astype(np.float64), expected[good]
    b = b * ((a * b).sum() / (b * b).sum())
    return a, b, b.max()


def band_psnr(cube, expected, good):
    """Per-band PSNR after one gain (as ``accuracy_table._chart_scan_scores``)."""
    a, b, peak = _scaled(cube, expected, good)
    return 10 * np.log10(peak**2 / ((a - b) ** 2).mean(axis=0))


def patch_bias_psnr(cube, expected, good) -> NDArray[np.float64]:
    """Per-band PSNR of the error of each patch's mean, after the gain of :func:`band_psnr`.

    A patch is the set of good pixels the truth gives one spectrum; each pixel is charged
    its patch's mean error, so what is left is the systematic part of the cube's error.
    """
    a, b, peak = _scaled(cube, expected, good)
    _, label = np.unique(np.round(b / peak, 6), axis=0, return_inverse=True)
    label = label.ravel()
    counts = np.bincount(label)
    error = a - b
    means = np.stack([np.bincount(label, error[:, k]) for k in range(b.shape[1])], 1)
    charged = (means / counts[:, None])[label]
    return 10 * np.log10(peak**2 / (charged**2).mean(axis=0))


def best_per_band(scan, model, expected):
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
        bands.append(band_psnr(cube, expected, good))
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
        "--separable",
        action="store_true",
        help="assemble with the separable row unmixing (the scan's default mixes blurs)",
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
    rows, cpu, parts = {}, {}, {}

    def measure(name, session):
        start = time.process_time()
        scan = assemble_scan(
            session,
            bundle,
            keep_raw=True,
            progress=False,
            unmixing="separable" if args.separable else "mixed",
        )
        cpu[name] = time.process_time() - start
        good = scan.quality == 0
        rows[name] = band_psnr(scan.cube, expected, good)
        parts[name] = (scan.band_noise_psnr_db, patch_bias_psnr(scan.cube, expected, good))
        rows[f"{name}, best strength per band"] = best_per_band(scan, model, expected)

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
    print(
        "\nthe error's parts, 500-600 / 580-640 / > 650 nm: the cube's own noise "
        "(band_noise_psnr_db) and the error of each patch's mean"
    )
    print("| | own noise | patch means |\n| --- | --- | --- |")
    for name in parts:
        cells = [" / ".join(f"{v[m].mean():.1f}" for m in (mid, orange, red)) for v in parts[name]]
        print(f"| {name} | {cells[0]} dB | {cells[1]} dB |")
    print("\nassembly CPU: " + ", ".join(f"{k} {v:.1f} s" for k, v in cpu.items()))
    print("\nnm " + " ".join(f"{w:6.1f}" for w in wl[::4]))
    for name, band in rows.items():
        print(f"{name}: " + " ".join(f"{v:6.1f}" for v in band[::4]))


if __name__ == "__main__":
    main()
