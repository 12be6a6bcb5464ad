"""Snapshot speed per frame at the SASSI paper's SLM crop (698 x 931), as video runs it.

Builds a prototype-like bundle for a 698 x 931 SLM (``--slm prototype``: the whole
1920 x 1080 SLM of ``sim-prototype``; 1 camera px per SLM px, 68 px streaks over
400-700 nm, blur sigma 1.7 px at 405 and 635 nm and 0.42 px at 520 nm, a guide camera of
1440 x 1080 px) and a guide image (scikit-image's coffee photograph), writes a few
2048 x 2048 spectral frames (camera noise: the work does not depend on the content) into a
session, and runs :class:`~sassi_bench.snapshot.video.VideoPipeline` frame after frame at
three mask densities: the bundle's own spacing (streak footprints never overlap), the
snapshot procedure's default 8-row pitch and the SASSI paper's 5-row pitch (dense: streaks
of neighbouring columns overlap and are unmixed jointly, the background refined from the
previous frame's). In each of ``--rounds`` rounds it times:

* reading one frame from the session (the baseline, as in the other benchmarks) and
  copying one dense float32 cube of the SLM at the bundle's 68 bins (the cost of merely
  touching a dense cube once);
* each step of a frame (wall clock and the CPU time of the thread that ran it, which the
  machine's other work inflates less): guide -> SLM warp, superpixels, the next frame's
  mask and its streak model (built beside this frame's spectra), the re-segmentation
  around the samples, the spectra at the open pixels (offset removal, extraction,
  deblur), the rank-1 cube in factored form; the frame's wall-clock
  total (spectra on one thread beside the segmentation on another: two cores) and the CPU
  time of the whole process over the frame (both threads, and the helper threads OpenCV
  runs some conversions on: what two cores must supply);
* outside the total: materialising the dense rank-1 cube (on demand only), and the masked
  guided filter in a rank-6 spectral basis (factored; and dense).

Medians over the rounds are printed, with each total's ratio to the frame read and to the
cube copy of its own round (the machine may be shared: ratios taken side by side are
steadier than absolute times). The paper: about 55 ms a frame (18 fps) on a GPU laptop.

At the paper's crop, the CPU ms per step of each density go to
``docs/_data/snapshot_frame.json`` (the table ``docs/performance.md`` quotes; one run
replaces it), unless ``--no-update``.

Run: ``python benchmarks/bench_snapshot.py [--rounds 7] [--slm crop|prototype] [--no-update]``
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from figures import update_columns
from threadpoolctl import threadpool_limits

from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import (
    CalibrationModels,
    DispersionModel,
    QuadraticBlur,
    QualityCheck,
    WavelengthBins,
    load,
    publish,
)
from sassi_bench.optics.glass import sellmeier_index
from sassi_bench.rig.config import load_rig_description
from sassi_bench.rig.frame import Frame, FrameMeta
from sassi_bench.snapshot import VideoPipeline, guided_factors

SLMS = {"crop": (698, 931), "prototype": (1080, 1920)}
CAMERA = (2048, 2048)
GUIDE = (1080, 1440)
BK7_B = (1.03961212, 0.231792344, 1.01046945)
BK7_C = (0.00600069867, 0.0200179144, 103.560653)


def prototype_models(slm: tuple[int, int] = SLMS["crop"]) -> CalibrationModels:
    """An SLM imaged 1:1 near the camera's centre, N-BK7, 68 px streaks."""
    n_blue, n_mid, n_red = sellmeier_index([400.0, 550.0, 700.0], BK7_B, BK7_C)
    x = np.zeros((3, 3))
    x[0, :3] = [1024.0, (slm[1] - 1) / 2, 2.0]  # centre, scale 1 along u, a little tilt
    x[1, 0] = -34.0  # s_x runs -1..1 over 400-700 nm: a 68 px streak
    y = np.zeros((3, 3))
    y[0, :3] = [1024.0, -1.5, (slm[0] - 1) / 2]
    y[1, 0], y[2, 0] = 0.4, 0.2  # smile
    dispersion = DispersionModel(
        "N-BK7", BK7_B, BK7_C, float(n_mid), float(n_blue - n_red) / 2, 550.0, 150.0, slm, 1, x, y
    )
    lam = np.linspace(400.0, 700.0, 4001)
    xs, _ = dispersion.evaluate((slm[1] - 1) / 2, (slm[0] - 1) / 2, lam)
    order = np.argsort(xs)
    x_edges = np.linspace(xs.min(), xs.max(), 69)
    edges = np.sort(np.interp(x_edges, xs[order], lam[order]))
    centres = (edges[:-1] + edges[1:]) / 2
    bins = WavelengthBins(centres, edges, 1.2 * np.diff(edges))
    blur = QuadraticBlur((0.42, 0.0, (1.7 - 0.42) / 1.15**2), 520.0, 100.0, 2.5)
    scale = slm[1] / GUIDE[1]
    homography = np.array([[scale, 0.0, 0.0], [0.0, scale, -10.0], [0.0, 0.0, 1.0]])
    return CalibrationModels(
        dispersion=dispersion,
        bins=bins,
        blur=blur,
        guide_to_slm=homography,
        guide_info={"rms_px": 0.05},
        offset=None,
        response=None,
    )


def guide_image() -> np.ndarray:
    """The coffee photograph at the guide camera's size, 12-bit-like float32."""
    from skimage import data

    photo = cv2.resize(data.coffee(), (GUIDE[1], GUIDE[0]), interpolation=cv2.INTER_CUBIC)
    return (photo.astype(np.float32) / 255.0) * 4000.0


def timed(fn, *args, **kwargs):
    """``fn``'s result and its (wall, thread CPU) seconds."""
    start, cpu = time.perf_counter(), time.thread_time()
    out = fn(*args, **kwargs)
    return out, (time.perf_counter() - start, time.thread_time() - cpu)


STEPS_PRINTED = (
    ("warp", "guide -> SLM warp"),
    ("superpixels", "superpixels (SLIC at half size)"),
    ("mask", "next frame's mask given superpixels"),
    ("model", "next frame's streak model (from its mask)"),
    ("resegment", "re-segmentation around samples"),
    ("spectra", "spectra (offset, extraction, deblur)"),
    ("rank1", "rank-1 cube, factored"),
)


#: The data file's rows, each from the medians of one density: (row, step, CPU or wall).
DATA_ROWS = (
    ("guide -> SLM warp", ("warp",), "cpu"),
    ("superpixels (SLIC at half size)", ("superpixels",), "cpu"),
    ("next frame's mask", ("mask",), "cpu"),
    ("next frame's streak model (from its mask)", ("model",), "cpu"),
    ("re-segmentation around the samples", ("resegment",), "cpu"),
    ("spectra (offset from the previous frame, extraction, deblur)", ("spectra",), "cpu"),
    ("rank-1, factored", ("rank1",), "cpu"),
    ("sum of the steps", ("steps",), "cpu"),
    ("the busier thread (spectra and streak model)", ("spectra", "model"), "cpu"),
    ("CPU of the whole process a frame (both threads, OpenCV's helpers)", ("process",), "cpu"),
    ("frame total, wall", ("total",), "wall"),
    ("not in the total: guided filter, rank 6, factored", ("guided",), "wall"),
)


def run_density(name, bundle, spacing, session, guide, rounds, cube, copy_of):
    """Frames of one mask density: prints their medians; returns the data file's column."""
    pipeline = VideoPipeline(bundle, spacing)
    mask, samples = pipeline.plan(guide)
    # Once untimed: compiles the kernels and refines the first background from scratch.
    frame, (cold, _) = timed(
        pipeline.process, guide, session.read_frame(0), mask, samples, exposure_s=0.1
    )
    frame.rank1.dense(cube)
    guided_factors(frame.guide_slm, frame.mask, frame.spectra).dense(cube)
    rows = []
    for r in range(rounds):
        raw, read = timed(session.read_frame, r % 3)
        _, copy = timed(np.copyto, cube, copy_of)
        mask, samples = frame.next_mask, frame.next_samples
        process = time.process_time()
        frame = pipeline.process(guide, raw, mask, samples, exposure_s=0.1)
        process = time.process_time() - process
        _, dense = timed(frame.rank1.dense, cube)
        guided, guided_s = timed(guided_factors, frame.guide_slm, mask, frame.spectra)
        _, guided_dense = timed(guided.dense, cube)
        wall, cpu = frame.seconds, frame.cpu_seconds
        steps = [key for key, _ in STEPS_PRINTED]
        row = {key: (wall[key], cpu[key]) for key in steps}
        row["steps"] = (sum(wall[k] for k in steps), sum(cpu[k] for k in steps))
        row["total"] = (wall["total"], float("nan"))
        row["process"] = (process, process)
        rows.append(
            dict(row, read=read, copy=copy, dense=dense, guided=guided_s, guided_dense=guided_dense)
        )
    pipeline.close()
    print(
        f"\n== {name}: {spacing.pitch}-row pitch, {int(mask.sum())} open pixels "
        f"({mask.mean() * 100:.2f} % of the SLM), {len(samples)} samples; first frame "
        f"(background from scratch, kernels compiled) {cold:.2f} s"
    )
    median = {key: statistics.median(row[key][0] for row in rows) for key in rows[0]}
    cpu = {key: statistics.median(row[key][1] for row in rows) for key in rows[0]}
    print(f"{'step':46s} {'ms':>7s} {'cpu ms':>7s} {'/ read':>7s} {'/ copy':>7s}")
    table = [("read", "read one frame (baseline)"), ("copy", "copy one dense cube (baseline)")]
    table += list(STEPS_PRINTED)
    table += [
        ("steps", "sum of the steps (one core)"),
        ("total", "per frame total, wall clock (two threads)"),
        ("process", "per frame, CPU of every thread of the process"),
        ("dense", "rank-1 dense cube, on demand (not in total)"),
        ("guided", "guided filter, rank 6, factored (not in total)"),
        ("guided_dense", "guided filter dense cube, on demand"),
    ]
    for key, label in table:
        print(
            f"{label:46s} {1e3 * median[key]:7.1f} {1e3 * cpu[key]:7.1f} "
            f"{median[key] / median['read']:6.1f}x {median[key] / median['copy']:6.2f}x"
        )
    ratios = sorted(row["total"][0] / row["read"][0] for row in rows)
    copies = sorted(row["total"][0] / row["copy"][0] for row in rows)
    print(
        f"total / read, per round: median {statistics.median(ratios):.1f}x (range "
        f"{ratios[0]:.1f}-{ratios[-1]:.1f}x); total / cube copy: median "
        f"{statistics.median(copies):.2f}x (range {copies[0]:.2f}-{copies[-1]:.2f}x); "
        f"{1 / median['total']:.1f} frames per second; CPU of the steps "
        f"{1e3 * cpu['steps']:.0f} ms (one core's share of the budget: the two threads "
        f"split it)"
    )
    chosen = {"cpu": cpu, "wall": median}
    values = {
        row: f"{1e3 * sum(chosen[kind][key] for key in keys):.0f}" for row, keys, kind in DATA_ROWS
    }
    return {"key": f"{name} ({int(mask.sum())} open px)", "values": values}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--slm", choices=sorted(SLMS), default="crop")
    parser.add_argument(
        "--pitches", default="bundle,8,5", help="mask densities: row pitches, 'bundle' = its own"
    )
    parser.add_argument("--no-update", action="store_true", help="print only")
    args = parser.parse_args()
    slm = SLMS[args.slm]
    columns = []
    with tempfile.TemporaryDirectory() as scratch, threadpool_limits(1, "blas"):
        bundle = load(
            publish(
                prototype_models(slm),
                rig={"name": "bench-crop"},
                quality={"checks": [QualityCheck.at_most("synthetic", 0.0, 1.0, "px")]},
                procedure={},
                inputs=[],
                data=Path(scratch),
            )
        )
        rng = np.random.default_rng(0)
        rig = load_rig_description("sim-prototype")
        steps = tuple(Step("spectral", "led", 0.1, {"kind": "blank"}, {}) for _ in range(3))
        session = Session.create(rig, Plan("bench", steps, {}), session_id="bench", data=scratch)
        for i in range(3):
            noise = rng.poisson(200.0, CAMERA).astype(np.uint16) + np.uint16(100)
            session.write_frame(i, Frame(noise, FrameMeta("spectral", 0.1, 0.0, None, "led", i)))
        guide = guide_image()
        cube = np.empty((*slm, bundle.wavelengths.size), np.float32)
        copy_of = np.ones_like(cube)
        print(f"SLM {slm[0]} x {slm[1]}, {bundle.wavelengths.size} bins, camera {CAMERA}")
        for pitch in args.pitches.split(","):
            row_pitch = None if pitch == "bundle" else int(pitch)
            spacing = bundle.mask_spacing(row_pitch=row_pitch)
            name = "bundle's spacing" if row_pitch is None else f"row pitch {row_pitch}"
            columns.append(
                run_density(name, bundle, spacing, session, guide, args.rounds, cube, copy_of)
            )
    if args.slm == "crop" and not args.no_update:
        title = "A snapshot frame at the paper's 698 x 931 crop, CPU ms per step"
        rows = [row for row, _, _ in DATA_ROWS]
        path = update_columns("snapshot_frame", title, rows, columns, "step, ms", replace=True)
        print(f"\nwritten: {path} (python benchmarks/figures.py updates the pages)")


if __name__ == "__main__":
    main()
