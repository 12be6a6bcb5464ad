"""Where the red end's error comes from when there is no noise: the forward model's misfit.

On the virtual bench, the chart scan's plan (a chain's ``<session>-macbeth``) is rendered
again with the sensor's photon and read noise off and no rounding (float frames handed
to the scan assembly directly, not stored), so what is left is deterministic:

1. per (chart patch, field point) the mean column sums of the patch's interior pixels
   (8 px from any other patch) against the forward model applied to the bench's own
   light in every bin (guard bins too), after one gain fitted at 450-600 nm: the misfit
   per band, which the deblur then inverts, for the chart's patches, its black mat
   and its surround apart;
2. those patch means deblurred at fixed weights (no rule), against the truth's patch
   means: the misfit as the inverse amplifies it, mid band and beyond 650 nm, for all
   groups and for each part.

With ``--pitch-15`` the pinholes are 15 rows apart (no streaks stacked, no row
unmixing). The truth is the bench's: this is a benchmark, not a procedure. About two
minutes of CPU on ``sim``.

Run: ``python benchmarks/red_end_misfit.py --data DIR --session bench-chain-macbeth``
(``--data`` the chain's staging folder holding the session and the bundle).
"""

from __future__ import annotations

import argparse

import numpy as np
from red_end_bound import sparse_plan

from sassi_bench import open_rig
from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.optics import sensor
from sassi_bench.rig.sim import truth
from sassi_bench.spectra.deblur import MeanDeblur
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.priors import RelativeSmoothnessPrior
from sassi_bench.spectra.scan import ScanAssembly

#: Fixed weights the patch means are deblurred at.
WEIGHTS = (1e-8, 1e-6, 1e-4, 1e-2)

#: Interior: every pixel this far away (SLM px) shows the same patch.
INTERIOR_PX = 8


def _exact(self, electron_rate, exposure_s, rng):
    """The sensor's mean reading, unrounded (:meth:`SensorModel.expose` without noise)."""
    mean = (np.asarray(electron_rate, np.float64) + self.dark_current_e_per_s) * exposure_s
    return mean / self.gain_e_per_adu + self.dark_offset_adu


def exact_scan(rig_name, session, bundle):
    """The frames of ``session``'s plan rendered without noise or rounding, assembled."""
    rig = open_rig(rig_name)
    rig.set_scene(session.plan.parameters["scene"])
    assembly = ScanAssembly(session.plan, session.rig, bundle, keep_raw=True)
    expose = sensor.SensorModel.expose
    sensor.SensorModel.expose = _exact
    try:
        for index in assembly.steps:
            step = session.plan.steps[index]
            rig.light.select(step.light)
            rig.spectral_camera.set_exposure(step.exposure_s)
            rig.slm.show(render_pattern(step.pattern, rig.slm.shape))
            assembly.read(index, rig.spectral_camera.capture().data)
    finally:
        sensor.SensorModel.expose = expose
    return assembly.finish(progress=False)


def patch_labels(reflectance):
    """(H, W) patch index of every SLM pixel, and whether it is in a patch's interior."""
    flat = np.round(reflectance.reshape(-1, reflectance.shape[-1]), 6)
    _, label = np.unique(flat, axis=0, return_inverse=True)
    label = label.reshape(reflectance.shape[:2])
    interior = np.ones(label.shape, bool)
    for dy in range(-INTERIOR_PX, INTERIOR_PX + 1, 4):
        for dx in range(-INTERIOR_PX, INTERIOR_PX + 1, 4):
            interior &= np.roll(label, (dy, dx), (0, 1)) == label
    return label, interior


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rig", default="sim")
    parser.add_argument("--data", required=True, help="folder holding the session and bundle")
    parser.add_argument("--session", required=True, help="the chart scan's session id")
    parser.add_argument("--pitch-15", action="store_true", help="pinholes 15 rows apart")
    args = parser.parse_args()
    rig = open_rig(args.rig)
    t = truth(rig)
    bundle = load(rig=rig.description.name, data=args.data)
    source = Session.open(args.session, data=args.data)
    plan = source.plan
    scene, light = plan.parameters["scene"], plan.parameters["light"]
    if args.pitch_15:
        plan = sparse_plan(light, plan.steps[1].exposure_s, scene)
    # The assembly reads its plan from a session; this one only lends it the plan.
    holder = source if not args.pitch_15 else _PlanOnly(source, plan)
    scan = exact_scan(args.rig, holder, bundle)

    model = StreakForwardModel.from_bundle(bundle)
    reflectance, grid = t.scene_cube(scene)
    photons = t.light_samples(light).weights * t.quantum_efficiency(grid)
    step = np.gradient(grid)
    label, interior = patch_labels(reflectance)
    r0, c0 = scan.origin
    height, width = scan.quality.shape
    rows, cols = np.nonzero((scan.quality == 0) & interior[r0 : r0 + height, c0 : c0 + width])
    point = model.point(rows + r0, cols + c0)
    key = label[rows + r0, cols + c0].astype(np.int64) * 100000 + point
    groups, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)
    measured, predicted, truth_light = [], [], []
    for g, k in enumerate(groups):
        if counts[g] < 20:
            continue
        chosen = inverse == g
        p = int(k % 100000)
        r, c = rows[chosen][0] + r0, cols[chosen][0] + c0
        lam = model.wavelengths_nm[p]
        middle = 0.5 * (lam[1:] + lam[:-1])
        edges = np.r_[2 * lam[0] - middle[0], middle, 2 * lam[-1] - middle[-1]]
        edges[model.core.start : model.core.stop + 1] = bundle.bin_edges
        overlap = np.minimum(grid + step / 2, edges[1:, None]) - np.maximum(
            grid - step / 2, edges[:-1, None]
        )
        light = (np.clip(overlap, 0, None) / step) @ (reflectance[r, c] * photons)
        predicted.append(model.spill[p] @ light)
        truth_light.append(light)
        measured.append(scan.column_sums[rows[chosen], cols[chosen]].astype(np.float64).mean(0))
    measured, predicted, truth_light = map(np.array, (measured, predicted, truth_light))
    wl = np.asarray(bundle.wavelengths)
    core = np.arange(model.core.start, model.core.stop)
    mid, red = (wl > 500) & (wl < 600), wl > 650
    fit = core[(wl > 450) & (wl < 600)]
    gain = (measured[:, fit] * predicted[:, fit]).sum() / (predicted[:, fit] ** 2).sum()
    misfit = measured[:, core] / (gain * predicted[:, core]) - 1
    # The chart's patches, its black mat (the commonest label after the surround) and
    # the surround (the label at the SLM's corner), apart.
    kept = groups[counts >= 20]
    kind = kept // 100000
    surround = label[0, 0]
    mat = np.bincount(label[label != surround].ravel()).argmax()
    parts = {
        "patches": (kind != mat) & (kind != surround),
        "mat": kind == mat,
        "surround": kind == surround,
    }
    print(
        f"{len(measured)} (patch, field point) groups ("
        + ", ".join(f"{name} {chosen.sum()}" for name, chosen in parts.items())
        + "); column sums against the forward model, mean / RMS:"
    )
    print("| nm | " + " | ".join(parts) + " |\n| --- | --- | --- | --- |")
    for k in [*range(0, wl.size - 6, 6), *range(wl.size - 6, wl.size)]:
        cells = [
            f"{100 * misfit[chosen, k].mean():+.3f} / "
            f"{100 * np.sqrt((misfit[chosen, k] ** 2).mean()):.3f} %"
            for chosen in parts.values()
        ]
        print(f"| {wl[k]:.1f} | " + " | ".join(cells) + " |")

    operators = MeanDeblur(model, RelativeSmoothnessPrior.of(scan.mean_spectrum)).operators
    points = kept % 100000
    expected = gain * truth_light[:, core]
    print(
        "\npatch means deblurred at fixed weights, RMS error (% of each group's peak), "
        "500-600 nm / > 650 nm:"
    )
    print("| weight | all | " + " | ".join(parts) + " |\n| --- | --- | --- | --- | --- |")
    for weight in WEIGHTS:
        solved = operators.solve(measured, points, np.full(points.size, weight))[:, core]
        error = (solved - expected) / expected.max(axis=1, keepdims=True)
        rms = [
            [100 * np.sqrt((error[chosen][:, band] ** 2).mean()) for band in (mid, red)]
            for chosen in (np.ones(len(error), bool), *parts.values())
        ]
        cells = [f"{a:.3f} / {b:.3f} %" for a, b in rms]
        print(f"| {weight:g} | " + " | ".join(cells) + " |")


class _PlanOnly:
    """A session's stand-in carrying another plan (for the 15-row pitch)."""

    def __init__(self, session, plan):
        self._session, self.plan = session, plan
        self.completed = set(range(len(plan.steps)))

    def __getattr__(self, name):
        return getattr(self._session, name)


if __name__ == "__main__":
    main()
