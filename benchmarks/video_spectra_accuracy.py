"""Video spectra on the virtual bench: the extraction against the bench's truth, frame by
frame, with the background carried from frame to frame or estimated from scratch.

Captures (or resumes, in the data root given) a snapshot video of the natural scene moving
as the snapshot validation moves it (2 px, 1 px and 0.25 degrees a frame), each frame's
adaptive mask planned on the previous frame's guide image by the video pipeline, at the
procedure's 8-row pitch (``--row-pitch``). Then extracts every frame's spectra at its open
pixels:

* ``cold``: the background estimated from scratch (24 refinements, as a single snapshot);
* ``warm K``: from the previous frame's background, K refinements (the video pipeline; the
  first frame from scratch);

and scores them against the bench's truth (:meth:`BenchTruth.binned_cube` of the scene at
the frame's pose, at the open pixels; one gain over the whole video, as the truth is in
photo-electrons), as a PSNR of the spectra (peak: the truth's maximum) and a relative RMS
error. With ``--save FILE`` the spectra before the within-streak deblur are saved too
(``.npz``, no pickle), and ``--compare FILE`` prints how far another run's spectra (of
other code on the same frames: the same data root and prefix) lie from this run's, against
the noise (the Poisson and read noise of each bin's pixels, from the frame itself).

Run: ``python benchmarks/video_spectra_accuracy.py --data DIR [--frames 12]
[--row-pitch 8] [--save FILE] [--compare FILE]``; the data root must hold a calibrated
``sim`` bundle (copy one first: the capture writes sessions into it).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from sassi_bench import open_rig
from sassi_bench.acquire.snapshots import capture_snapshots
from sassi_bench.bundle import load
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.sim import truth
from sassi_bench.snapshot import VideoPipeline, measure_with_background
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.extract import extract_with_background
from sassi_bench.spectra.geometry import reached_rows, streak_geometry

WARM = (1, 2, 4)


def capture(data: Path, frames: int, row_pitch: int, prefix: str):
    """The video (resumed when its sessions exist) and the rig and bundle it used."""
    rig = open_rig("sim")
    bundle = load(rig="sim", data=data)
    procedure = load_procedure("snapshot_validation")
    motion_cfg = procedure["video"]
    motion = (tuple(motion_cfg["shift_px_per_frame"]), motion_cfg["rotation_deg_per_frame"])
    spacing = bundle.mask_spacing(row_pitch=row_pitch)
    planner = VideoPipeline(bundle, spacing, threads=1)
    video = capture_snapshots(
        rig, lambda guide: planner.plan(guide)[0], prefix=prefix, frames=frames,
        scene="natural", light=procedure["snapshot"]["light"],
        exposure_pattern={"kind": "pinholes", "pitch": [spacing.uniform_step, spacing.pitch]},
        motion=motion, data=data, progress=True,
    )  # fmt: skip
    planner.close()
    return rig, bundle, video, procedure["snapshot"]["light"]


def raw_amplitudes(bundle, frame, mask):
    """The spectra before the within-streak deblur (24 refinements from scratch), the bin
    sums' noise, in camera units per frame."""
    top, bottom = reached_rows(bundle, frame.shape[0])
    window = frame[top:bottom]
    rows, cols = np.nonzero(mask)
    geometry = streak_geometry(bundle, rows, cols).shifted(top)
    amplitudes, _, _ = extract_with_background(window, geometry, None, passes=24)
    # Each bin sums ~(its columns x a few sigmas of rows) pixels, each with the background
    # (the window's median: a rough level) and the streak's share of photon noise.
    core = geometry.core
    cells = (geometry.x_right - geometry.x_left)[:, core] * 6.0 * geometry.sigma[core]
    noise = np.sqrt(np.abs(amplitudes) + cells * float(np.median(window)))
    return amplitudes, noise


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", required=True, help="data root with a calibrated sim bundle")
    parser.add_argument("--frames", type=int, default=12)
    parser.add_argument("--row-pitch", type=int, default=8)
    parser.add_argument("--prefix", default="video-accuracy")
    parser.add_argument("--save", help="save the raw (pre-deblur) spectra to this .npz")
    parser.add_argument("--compare", help="a --save file of another run on the same frames")
    args = parser.parse_args()
    data = Path(args.data)
    rig, bundle, video, light = capture(data, args.frames, args.row_pitch, args.prefix)
    exposure = video.exposures.spectral_s
    deblur = SpectralDeblur.from_bundle(bundle)
    bench = truth(rig)
    methods = {"cold": [], **{f"warm {k}": [] for k in WARM}}
    backgrounds = dict.fromkeys(WARM)
    reference, raw, noise = [], [], []
    for t in range(args.frames):
        frame, mask = video.spectral(t), video.mask(t)
        rows, cols = np.nonzero(mask)
        cube = bench.binned_cube(bundle.bin_edges, light, "natural", video.pose(t))
        reference.append(cube[rows, cols])
        spectra, _, _ = measure_with_background(
            frame, mask, bundle, exposure_s=exposure, deblur=deblur
        )
        methods["cold"].append(spectra)
        for k in WARM:
            start = backgrounds[k]
            if start is not None and not hasattr(start, "values"):
                start = start.image  # an older extraction's background: its image
            spectra, _, backgrounds[k] = measure_with_background(
                frame, mask, bundle, exposure_s=exposure, deblur=deblur,
                background_passes=k if start is not None else None, background_start=start,
            )  # fmt: skip
            methods[f"warm {k}"].append(spectra)
        amplitudes, sigma = raw_amplitudes(bundle, frame, mask)
        raw.append(amplitudes)
        noise.append(sigma)
    truth_all = np.concatenate(reference)
    peak = float(truth_all.max())
    print(
        f"{args.frames} frames of the natural scene moving, {args.row_pitch}-row pitch, "
        f"{np.mean([r.shape[0] for r in reference]):.0f} open pixels a frame"
    )
    print(f"{'spectra':10s} {'PSNR dB':>8s} {'rel. RMS':>9s}   per frame (dB)")
    for name, values in methods.items():
        measured = np.concatenate(values)
        gain = float((measured * truth_all).sum() / (measured * measured).sum())
        error = gain * measured - truth_all
        psnr = 10 * np.log10(peak**2 / np.mean(error**2))
        per_frame = [
            10 * np.log10(peak**2 / np.mean((gain * v - r) ** 2))
            for v, r in zip(values, reference, strict=True)
        ]
        relative = np.sqrt(np.mean(error**2) / np.mean(truth_all**2))
        print(f"{name:10s} {psnr:8.2f} {relative:9.4f}   {' '.join(f'{p:.1f}' for p in per_frame)}")
    if args.save:
        np.savez(args.save, *raw, allow_pickle=False)
    if args.compare:
        with np.load(args.compare, allow_pickle=False) as other:
            theirs = [other[f"arr_{t}"] for t in range(args.frames)]
        difference = np.concatenate([a - b for a, b in zip(raw, theirs, strict=True)])
        sigma = np.concatenate(noise)
        values = np.concatenate(raw)
        scaled = difference / sigma
        print(
            f"pre-deblur spectra against {args.compare}: RMS difference "
            f"{np.sqrt(np.mean(difference**2)):.4g} (of RMS {np.sqrt(np.mean(values**2)):.4g}); "
            f"in units of each bin's noise: RMS {np.sqrt(np.mean(scaled**2)):.2e}, "
            f"max {np.abs(scaled).max():.2e}"
        )


if __name__ == "__main__":
    main()
