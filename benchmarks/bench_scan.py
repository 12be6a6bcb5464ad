"""Pinhole-scan assembly speed and memory, against merely reading the frames.

Captures a pinhole scan of the ColorChecker (all 500 frames, or every n-th with
``--every``) into a session, then times (a) reading every frame back from the session
store and (b) assembling the cube (reading pass + spectra pass), printing the ratio;
the target is <= 3x at the sim-prototype scale. Peak memory of the assembly is printed
beside the size of all frames, to show it streams (a few frames in memory at a time).

A bundle for the rig is needed: ``--bundle PATH``, or the spectral calibration runs first.

Run: ``python benchmarks/bench_scan.py [--rig sim-prototype] [--every 1] [--bundle DIR]
[--workers N]``
"""

from __future__ import annotations

import argparse
import tempfile
import time
import tracemalloc

from _bundle import bundle_for

from sassi_bench import open_rig
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.spectra.scan import assemble_scan, scan_plan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", default="sim-prototype")
    parser.add_argument("--every", type=int, default=1, help="keep every n-th scan frame")
    parser.add_argument("--bundle", help="bundle folder for the rig (default: calibrate first)")
    parser.add_argument("--workers", type=int, help="assembly threads (default: all CPUs)")
    args = parser.parse_args()
    rig = open_rig(args.rig)
    with tempfile.TemporaryDirectory() as data:
        bundle = bundle_for(rig, args.bundle, data)
        plan = scan_plan(rig.slm.shape, "led", 0.1, scene="colorchecker", closed_check=False)
        if args.every > 1:
            plan = Plan(plan.name, plan.steps[:: args.every], plan.parameters)
        session = Session.create(rig.description, plan, session_id="bench", data=data)
        start = time.perf_counter()
        run_plan(rig, plan, session, progress=True)
        print(f"capture (rendering) of {len(plan)} frames: {time.perf_counter() - start:.1f} s")
        start = time.perf_counter()
        size = 0
        for i in range(len(plan)):
            size += session.read_frame(i).nbytes
        read = time.perf_counter() - start
        start = time.perf_counter()
        scan = assemble_scan(session, bundle, progress=False, workers=args.workers)
        assemble = time.perf_counter() - start
        # Memory in a second run: tracing every allocation would slow the timed one.
        tracemalloc.start()
        assemble_scan(session, bundle, progress=False, workers=args.workers)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    frames = len(plan)
    print(f"read all frames from the store: {read:8.2f} s  ({1e3 * read / frames:6.1f} ms/frame)")
    print(
        f"assemble the cube:              {assemble:8.2f} s  ({1e3 * assemble / frames:6.1f} "
        f"ms/frame) = {assemble / read:5.1f}x reading (target <= 3x)"
    )
    print(
        f"peak traced memory {peak / 2**20:8.1f} MiB; all frames {size / 2**20:8.1f} MiB; "
        f"cube {scan.cube.nbytes / 2**20:8.1f} MiB"
    )


if __name__ == "__main__":
    main()
