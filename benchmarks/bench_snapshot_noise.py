"""Adaptive snapshots against the guide camera's noise: how much one run's figures move.

On the ``sim`` bench, takes the same adaptive snapshot of a scene ``--realisations``
times (each a fresh preview and spectral frame, so the guide camera's and the spectral
camera's noise differ while the scene, light and exposures do not), reconstructs each and
scores rank-1, the guided filter and rank-1 on the detail pixels against the bench's true
cube. Prints one line per realisation and, per figure, the mean, minimum, maximum and
spread (max - min): the adaptive plan is robust when the spread is small.

Scores: one least-squares gain of the truth for the whole cube (units differ), over the SLM
pixels ``scoring.border_px`` or more from its edges; the detail pixels are the
``scoring.detail_fraction`` of those of strongest gradient in the truth
(:func:`~sassi_bench.validate.snapshot.detail_pixels`), scored with the same gain and
peak. The bundle is the spectral calibration with the bench's true guide homography (as
the tests' fixture: the guide registration is not what is measured here); ``--bundle``
reuses one.

Run: ``python benchmarks/bench_snapshot_noise.py [--realisations 8] [--scene natural]
[--bundle PATH] [--low-light 1.0]``
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from sassi_bench import open_rig
from sassi_bench.bundle import CalibrationModels, load, publish
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.snapshots import reconstruct_snapshots
from sassi_bench.rig.sim import truth
from sassi_bench.validate.snapshot import detail_pixels
from sassi_bench.workflows.snapshot import take_snapshots

FIGURES = ("rank1", "guided", "detail_rank1")


def sim_bundle(rig, data: Path):
    """The rig's spectral calibration with its true guide homography added."""
    from sassi_bench.workflows.spectral import run_spectral_calibration

    result = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=data, progress=True, session_id="cal"
    )
    old = load(result.bundle_path).models
    models = CalibrationModels(
        dispersion=old.dispersion, bins=old.bins, blur=old.blur,
        guide_to_slm=truth(rig).guide_to_slm,
        guide_info={"rms_px": 0.0, "note": "true homography (benchmark)"},
        offset=old.offset, response=old.response,
    )  # fmt: skip
    path = publish(
        models, rig=rig.description, quality={"checks": [], "residuals": {}},
        procedure={"benchmark": "spectral calibration plus the true guide homography"},
        data=data,
    )  # fmt: skip
    return load(path)


def one_gain_scores(cube, reference, valid, detail) -> dict[str, float]:
    """PSNR (dB) over ``valid`` and over ``detail`` after one least-squares gain on the
    reference fitted over ``valid`` (peak: the scaled reference's maximum there)."""
    est = cube[valid].astype(np.float64)
    ref = reference[valid].astype(np.float64)
    gain = (est * ref).sum() / (ref * ref).sum()
    peak = gain * ref.max()

    def db(where):
        error = cube[where].astype(np.float64) - gain * reference[where]
        return float(10 * np.log10(peak**2 / np.mean(error**2)))

    return {"all": db(valid), "detail": db(detail)}


def measure(realisations: int, scene: str, bundle_path: str | None, low_light: float, data):
    rig = open_rig("sim")
    bundle = load(bundle_path) if bundle_path else sim_bundle(rig, data)
    procedure = load_procedure("snapshot_validation")
    light = procedure["snapshot"]["light"]
    reference = truth(rig).binned_cube(bundle.bin_edges, light, scene)
    border = int(procedure["scoring"]["border_px"])
    valid = np.zeros(bundle.slm_shape, bool)
    valid[border:-border, border:-border] = True
    detail = detail_pixels(reference, valid, float(procedure["scoring"]["detail_fraction"]))
    rows = []
    for k in range(realisations):
        start = time.perf_counter()
        video = take_snapshots(
            rig, bundle, procedure, scene=scene, low_light=low_light,
            session_id=f"noise-{int(time.time())}-{k}", data=data, progress=False,
        )  # fmt: skip
        frame = next(reconstruct_snapshots(video, bundle, procedure, progress=False))
        rank1 = one_gain_scores(frame.rank1, reference, valid, detail)
        guided = one_gain_scores(frame.guided, reference, valid, detail)
        row = {"rank1": rank1["all"], "guided": guided["all"], "detail_rank1": rank1["detail"]}
        rows.append(row)
        print(
            f"realisation {k}: open {int(frame.mask.sum())}, regions {len(frame.samples)}, "
            + ", ".join(f"{name} {value:.2f} dB" for name, value in row.items())
            + f" ({time.perf_counter() - start:.0f} s)",
            flush=True,
        )
    print(f"\n{scene}, {realisations} noise realisations (PSNR dB against the truth):")
    print(f"{'figure':14s} {'mean':>7s} {'min':>7s} {'max':>7s} {'spread':>7s}")
    for name in FIGURES:
        values = [row[name] for row in rows]
        spread = max(values) - min(values)
        print(
            f"{name:14s} {statistics.fmean(values):7.2f} {min(values):7.2f} "
            f"{max(values):7.2f} {spread:7.2f}"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--realisations", type=int, default=8)
    parser.add_argument("--scene", default="natural")
    parser.add_argument("--bundle", help="a published sim bundle with a guide homography")
    parser.add_argument("--low-light", type=float, default=1.0)
    parser.add_argument("--data", help="data root (default: a temporary folder)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(args.data or tmp)
        measure(args.realisations, args.scene, args.bundle, args.low_light, data)


if __name__ == "__main__":
    main()
