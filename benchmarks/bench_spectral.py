"""Spectral calibration: frames per laser for each sweep mode, and decoding speed.

For both rig scales this prints how many frames one laser costs in each sweep mode
(structured light versus the paper's one-line-at-a-time sweep, and its multi-line
shift), then captures one laser's structured-light sweep into a session on disk and
times decoding it (Gray code + phase shifting on both axes, then the smooth field fit)
against the time to merely read the same frames back from the session store.

Run: ``python benchmarks/bench_spectral.py [--rig sim] [--rig sim-prototype]``
"""

from __future__ import annotations

import argparse
import tempfile
import time

from sassi_bench import open_rig
from sassi_bench.acquire.plan_geometry import planned_spectral
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import sweep_plan
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.sweeps import analyse_sweep

LASER = 532.0


def frames_per_laser(
    proc: dict, shape: tuple[int, int], mode: str, spacing: int, stride: int
) -> int:
    p = {
        **proc,
        "sweep": {
            **proc["sweep"],
            "mode": mode,
            "line_spacing_px": spacing,
            "line_stride_px": stride,
        },
    }
    plan = sweep_plan(p, shape, {LASER: 0.01}, list(range(0, 256, 16)))
    return len(plan.select(laser=LASER))


def bench(name: str) -> None:
    rig = open_rig(name)
    shape = rig.slm.shape
    proc = planned_spectral(load_procedure("spectral_calibration"), rig.description)
    print(f"\n== {name}: SLM {shape[1]}x{shape[0]} ==")
    rows = [
        ("structured light (Gray + phase)", "structured", 64, 8),
        ("line sweep, one line at a time, stride 1", "lines", max(shape), 1),
        ("line sweep, stride 8", "lines", max(shape), 8),
        ("line sweep, multi-line (64 px apart), stride 8", "lines", 64, 8),
    ]
    base = None
    for label, mode, spacing, stride in rows:
        n = frames_per_laser(proc, shape, mode, spacing, stride)
        base = base or n
        print(f"  frames per laser, {label:48s} {n:6d}  ({n / base:5.1f}x structured)")

    with tempfile.TemporaryDirectory() as data:
        session = Session.create(
            rig.description, plan_for(proc, shape), session_id="bench", data=data
        )
        start = time.perf_counter()
        run_plan(rig, session.plan, session, progress=False)
        capture = time.perf_counter() - start
        indices = list(range(len(session.plan)))
        start = time.perf_counter()
        for i in indices:
            session.read_frame(i)
        read = time.perf_counter() - start
        start = time.perf_counter()
        analyse_sweep(session, proc, shape, saturation=65535)
        decode = time.perf_counter() - start
    print(f"  {len(indices)} frames of one laser: capture (render) {capture:6.1f} s")
    print(f"  read back from the session store      {read:6.2f} s")
    print(
        f"  decode + field fit (includes reading) {decode:6.2f} s  = {decode / read:5.1f}x reading"
    )


def plan_for(proc: dict, shape: tuple[int, int]):
    from sassi_bench.calibrate.grey_response import sinusoid_profile

    profile = sinusoid_profile(int(proc["sweep"]["phase_period_px"]), None).tolist()
    plan = sweep_plan(proc, shape, {LASER: 0.02}, profile)
    keep = [s for s in plan.steps if s.tags.get("role") not in ("pinholes", "blur-blank")]
    return type(plan)(plan.name, tuple(keep), plan.parameters)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", action="append", help="rig(s) (default: sim and sim-prototype)")
    args = parser.parse_args()
    for name in args.rig or ["sim", "sim-prototype"]:
        bench(name)


if __name__ == "__main__":
    main()
