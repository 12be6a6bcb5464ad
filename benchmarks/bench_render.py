"""Rendering speed of the virtual bench.

Frames per second for three kinds of frame at both rig scales:

* a pinhole pattern (100 x 5 px pitch) under the white LED, the frame of a ground-truth
  scan (sparse renderer);
* a dense binary stripe pattern under a laser, the frame of a structured-light sweep
  (dense renderer);
* an all-open SLM under the white LED (dense renderer, every wavelength sample).

Each time is also printed as a ratio to a baseline measured in the same run: adding
sensor noise to an empty frame, the cost no renderer can avoid. The target of the
foundation issue is checked at the end: the default rig renders a 500-frame pinhole
scan in under 60 s on 2 cores.

Run: ``python benchmarks/bench_render.py [--rig sim] [--frames 20]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sassi_bench import open_rig
from sassi_bench.acquire.patterns import pinhole_pattern
from sassi_bench.rig.sim import truth

TARGET_SCAN_S = 60.0
SCAN_FRAMES = 500


def _time_captures(rig, patterns, repeat: int) -> float:
    """Seconds per frame (show + capture), after one warm-up frame."""
    rig.slm.show(patterns[0])
    rig.spectral_camera.capture()
    start = time.perf_counter()
    for i in range(repeat):
        rig.slm.show(patterns[i % len(patterns)])
        rig.spectral_camera.capture()
    return (time.perf_counter() - start) / repeat


def _baseline(rig, repeat: int) -> float:
    bench = truth(rig).bench
    zeros = np.zeros(bench.camera_shape, np.float32)
    rng = np.random.default_rng(0)
    start = time.perf_counter()
    for _ in range(repeat):
        bench.sensor.expose(zeros, 0.01, rng)
    return (time.perf_counter() - start) / repeat


def bench_rig(name: str, frames: int) -> dict[str, float]:
    rig = open_rig(name)
    rig.set_scene("colorchecker")
    shape = rig.slm.shape
    baseline = _baseline(rig, frames)
    print(
        f"\n== {name}: SLM {shape[1]}x{shape[0]}, camera {rig.spectral_camera.shape[1]}x"
        f"{rig.spectral_camera.shape[0]} =="
    )
    print(f"baseline (sensor noise only): {baseline * 1e3:8.1f} ms/frame")

    rig.light.select("led")
    pinholes = [pinhole_pattern(shape, (100, 5), (i % 100, i % 5)) for i in range(frames)]
    t_pin = _time_captures(rig, pinholes, frames)

    rig.light.select(f"laser:{rig.description.lasers_nm[1]:g}")
    cols = np.arange(shape[1])
    stripes = [np.broadcast_to(((cols >> k) & 1).astype(bool), shape) for k in range(3, 10)]
    t_dense = _time_captures(rig, stripes, max(3, frames // 4))

    rig.light.select("led")
    t_open = _time_captures(rig, [np.ones(shape, bool)], 2)

    for label, t in [
        ("pinhole pattern, LED (sparse)", t_pin),
        ("stripe pattern, laser (dense)", t_dense),
        ("all-open SLM, LED (dense)", t_open),
    ]:
        print(
            f"{label:32s} {1 / t:8.2f} fps  {t * 1e3:9.1f} ms/frame  {t / baseline:7.1f}x baseline"
        )
    return {"pinhole": t_pin, "dense": t_dense, "open": t_open, "baseline": baseline}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", action="append", help="rig(s) to time (default: both scales)")
    parser.add_argument("--frames", type=int, default=20, help="pinhole frames to time")
    args = parser.parse_args()
    rigs = args.rig or ["sim", "sim-prototype"]
    results = {name: bench_rig(name, args.frames) for name in rigs}
    if "sim" in results:
        scan = results["sim"]["pinhole"] * SCAN_FRAMES
        verdict = "PASS" if scan < TARGET_SCAN_S else "FAIL"
        print(
            f"\n500-frame pinhole scan on the default rig: {scan:.1f} s "
            f"(target < {TARGET_SCAN_S:.0f} s): {verdict}"
        )


if __name__ == "__main__":
    main()
