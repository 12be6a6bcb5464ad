"""Rendering speed of the virtual bench, per kind of frame a calibration captures.

For each rig scale, the CPU time (all threads, ``time.process_time``) and the wall time
of one captured frame (show the pattern, render, add the sensor's noise) of each kind:

* **sensor noise only**: an empty frame through the sensor model, the cost no renderer
  avoids (also the baseline the other rows are divided by, measured in the same run);
* **dense Gray code**: a Gray-code bit under a laser (structured-light sweep; dense
  renderer, the laser's coarse inverse maps kept);
* **sparse pinholes**: a 100 x 5 pinhole frame under the white LED on the ColorChecker
  (a Macbeth or guide scan frame; sparse renderer over the closed-SLM background);
* **first sparse frame**: the same, with the closed-SLM background rendered first (once
  per scene, pose and light);
* **response frame**: a pinhole frame under the halogen lamp on the white diffuser;
* **guide frame**: the RGB guide camera under the LED.

Each kind is exposed as the procedures' auto-exposure would: its brightest pixel at 60 %
of the full well (the noise's cost depends on the electron counts). CPU time is the
comparable figure on a shared machine (wall time waits for cores).
Each row is the median of ``--frames`` frames after one warm-up (compilation) frame
(the first sparse frame: a third as many, at least 3); rigs timed together take turns
frame by frame.
A whole scan's time is measured, not multiplied out from one frame, by
``benchmarks/bench_chain.py`` (its "Macbeth scan and validation" stage).

With ``--design`` it times the optical-design rigs (``sim-achromat``, ``sim-singlet``)
against their parametric twins in the same run: the same rig with the relay, prism and
blur its design condenses to (:func:`~sassi_bench.optics.design.nominal_summary`), so the
same SLM, camera and streak length, rendered by the parametric bench; it prints each
frame's ratio of the design bench's CPU time to the twin's (target: within 1.5x).

Run: ``python benchmarks/bench_render.py [--rig sim] [--frames 5] [--design]``
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from sassi_bench import open_rig
from sassi_bench.acquire.patterns import gray_bit_count, pinhole_pattern, render_pattern
from sassi_bench.rig.sim import truth


def _measure(action: Callable[[int], object], i: int) -> tuple[float, float]:
    """(CPU s, wall s) of one ``action(i)``."""
    start = (time.process_time(), time.perf_counter())
    action(i)
    return time.process_time() - start[0], time.perf_counter() - start[1]


def _timed_together(
    actions: list[Callable[[int], object]], repeat: int
) -> list[tuple[float, float]]:
    """Median (CPU s, wall s) of each action over ``repeat`` calls, after a warm-up each.

    The actions take turns frame by frame (A B A B ...), so a slow spell of the machine
    falls on all of them alike rather than on whichever ran through it.
    """
    for action in actions:
        action(0)
    times: list[list[tuple[float, float]]] = [[] for _ in actions]
    for i in range(1, repeat + 1):
        for action, kept in zip(actions, times, strict=True):
            kept.append(_measure(action, i))
    return [
        (statistics.median(c for c, _ in kept), statistics.median(w for _, w in kept))
        for kept in times
    ]


def _expose_for(rig, pattern) -> None:
    """Set the spectral exposure that puts the pattern's brightest pixel at 60 % of the
    full well (within the camera's range)."""
    bench = truth(rig).bench
    rig.slm.show(pattern)
    peak = float(bench.spectral_rate().max())
    lo, hi = rig.spectral_camera.exposure_range_s
    exposure = 0.6 * bench.sensor.full_well_e / peak if peak > 0 else hi
    rig.spectral_camera.set_exposure(min(max(exposure, lo), hi))


def parametric_twin(name: str):
    """A design rig's description as a parametric rig: its derived relay, prism and blur
    in place of the design (same SLM, camera, lights and seed)."""
    from dataclasses import asdict

    from sassi_bench.rig.config import load_rig_description, rig_description_from_dict

    desc = load_rig_description(name)
    data = desc.to_dict()
    data.pop("design")
    data["name"] = f"{desc.name}-parametric"
    for key in ("relay", "prism", "blur"):
        data[key] = {k: v for k, v in asdict(getattr(desc, key)).items() if v is not None}
    data["blur"]["sigma_px"] = {str(k): v for k, v in data["blur"]["sigma_px"].items()}
    return rig_description_from_dict(data)


FrameKind = tuple[str, Callable[[], None], Callable[[int], object], int]


def frame_kinds(rig, frames: int) -> list[FrameKind]:
    """The kinds of frame timed on a rig: (label, set-up, one frame, frames to time)."""
    bench = truth(rig).bench
    shape = rig.slm.shape
    camera = rig.spectral_camera
    zeros = np.zeros(bench.camera_shape, np.float32)
    bits = gray_bit_count(shape[1], 8)
    laser = f"laser:{rig.description.lasers_nm[2]:g}"

    def lit(scene: str, light: str, pattern) -> Callable[[], None]:
        def set_up() -> None:
            rig.set_scene(scene)
            rig.light.select(light)
            _expose_for(rig, pattern)

        return set_up

    def noise(i: int) -> None:
        bench.sensor.expose(zeros, 0.01, np.random.default_rng(i))

    def gray(i: int) -> None:
        bit = {"kind": "gray", "axis": "x", "bit": i % bits, "block": 8, "inverse": bool(i % 2)}
        rig.slm.show(render_pattern(bit, shape))
        camera.capture()

    def pinholes(i: int) -> None:
        rig.slm.show(pinhole_pattern(shape, (100, 5), (i % 100, i % 5)))
        camera.capture()

    def first(i: int) -> None:
        bench._background.clear()
        pinholes(i)

    pinhole_grid = pinhole_pattern(shape, (100, 5))
    full = render_pattern({"kind": "full"}, shape)
    led = lit("colorchecker", "led", pinhole_grid)
    return [
        ("sensor noise only", lambda: None, noise, frames),
        ("dense Gray code (laser)", lit("colorchecker", laser, full), gray, frames),
        ("sparse pinholes (LED)", led, pinholes, frames),
        ("first sparse frame (+ background)", led, first, max(3, frames // 3)),
        ("response frame (halogen)", lit("white", "halogen", pinhole_grid), pinholes, frames),
        ("guide frame (LED)", led, lambda i: rig.guide_camera.capture(), frames),
    ]


def bench_rigs(names: list, frames: int) -> list[dict[str, tuple[float, float]]]:
    """Each rig's median (CPU s, wall s) per kind of frame, the rigs taking turns."""
    rigs = [open_rig(name) for name in names]
    kinds = [frame_kinds(rig, frames) for rig in rigs]
    results: list[dict[str, tuple[float, float]]] = [{} for _ in rigs]
    for j, (label, _, _, repeat) in enumerate(kinds[0]):
        for rig_kinds in kinds:
            rig_kinds[j][1]()
        timed = _timed_together([rig_kinds[j][2] for rig_kinds in kinds], repeat)
        for rows, median in zip(results, timed, strict=True):
            rows[label] = median
    for rig, rows in zip(rigs, results, strict=True):
        (h, w), (ch, cw) = rig.slm.shape, rig.spectral_camera.shape
        print(f"\n== {rig.description.name}: SLM {w}x{h}, camera {cw}x{ch} ==")
        base = rows["sensor noise only"][0]
        print(f"{'frame':36s} {'CPU ms':>9s} {'wall ms':>9s} {'CPU / noise':>12s}")
        for label, (cpu, wall) in rows.items():
            print(f"{label:36s} {cpu * 1e3:9.1f} {wall * 1e3:9.1f} {cpu / base:12.1f}")
    return results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", action="append", help="rig(s) to time (default: both scales)")
    parser.add_argument("--frames", type=int, default=5, help="frames timed per kind")
    parser.add_argument(
        "--design", action="store_true", help="design rigs against their parametric twins"
    )
    args = parser.parse_args()
    if args.design:
        for name in args.rig or ["sim-achromat", "sim-singlet"]:
            design, twin = bench_rigs([name, parametric_twin(name)], args.frames)
            print(f"\n{name}: CPU time per frame, design bench / parametric twin (target <= 1.5)")
            for label in design:
                ratio = design[label][0] / twin[label][0]
                verdict = (
                    " (the same work on both: the run's noise)"
                    if label.startswith("sensor")
                    else ""
                    if label.startswith("guide")
                    else (" ok" if ratio <= 1.5 else " OVER")
                )
                print(f"  {label:36s} {ratio:6.2f}{verdict}")
        return
    for name in args.rig or ["sim", "sim-prototype"]:
        bench_rigs([name], args.frames)


if __name__ == "__main__":
    main()
