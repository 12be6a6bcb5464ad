"""Pinhole-scan assembly speed and memory, against merely reading the frames.

Captures a pinhole scan of the ColorChecker (all 500 frames, or every n-th with
``--every``) into a session, then, in each of ``--rounds`` rounds, times (a) reading
every frame back from the session store and (b) assembling the cube (reading pass +
spectra pass), and prints the round's ratio; the target is <= 3x at the sim-prototype
scale for the full 500 frames. Reads and assemblies alternate because a shared machine's
speed drifts by tens of per cent within minutes: a ratio of two timings taken side by
side is steadier than one of two best times taken apart. The median of the rounds' ratios
is the figure to quote. Reading one frame after another is the baseline; since the
assembly reads on all its threads, the same read on that many threads is timed too and
its ratio printed beside. (With ``--every`` the costs that scale with the SLM, not with the
frames, such as the first touch of the cube's memory, weigh up to n times more per
frame.) The first assembly in the process, which also compiles the kernels, is timed and
printed apart. Peak memory of the assembly is printed beside the size of all frames, to
show it streams (a few frames in memory at a time).

A bundle for the rig is needed: ``--bundle PATH``, or the spectral calibration runs first.
``--session ID --data DIR`` times a scan session captured before (yours, or an earlier
run's) instead of capturing one (rendering 500 prototype frames takes about 6-15 minutes).

Run: ``python benchmarks/bench_scan.py [--rig sim-prototype] [--every 1] [--rounds 3]
[--bundle DIR] [--workers N] [--session ID --data DIR]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
import tracemalloc
from concurrent.futures import ThreadPoolExecutor

from _bundle import bundle_for

from sassi_bench import open_rig
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.reduce.scan import assemble_scan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", default="sim-prototype")
    parser.add_argument("--every", type=int, default=1, help="keep every n-th scan frame")
    parser.add_argument("--rounds", type=int, default=3, help="read/assemble rounds")
    parser.add_argument("--bundle", help="bundle folder for the rig (default: calibrate first)")
    parser.add_argument("--workers", type=int, help="assembly threads (default: all CPUs)")
    parser.add_argument("--session", help="time this captured scan session instead")
    parser.add_argument("--data", help="the data folder holding --session")
    args = parser.parse_args()
    if bool(args.session) != bool(args.data):
        parser.error("--session and --data go together")
    rig = open_rig(args.rig)
    with tempfile.TemporaryDirectory() as scratch:
        bundle = bundle_for(rig, args.bundle, scratch)
        if args.session:
            session = Session.open(args.session, data=args.data)
        else:
            session = _capture(rig, args.every, scratch)
        frames = sorted(session.completed)
        # The first assembly in a process also compiles the kernels (numba, once per
        # process); the later ones are the steady state a lab's long scans see.
        start = time.perf_counter()
        assemble_scan(session, bundle, progress=False, workers=args.workers)
        first = time.perf_counter() - start
        rounds = []
        workers = args.workers or os.cpu_count() or 1
        for _ in range(args.rounds):
            read, size = _read_all(session, frames)
            start = time.perf_counter()
            scan = assemble_scan(session, bundle, progress=False, workers=args.workers)
            assemble = time.perf_counter() - start
            rounds.append((read, assemble, _read_all(session, frames, workers)[0]))
        # Memory in a last run: tracing every allocation would slow the timed ones.
        tracemalloc.start()
        assemble_scan(session, bundle, progress=False, workers=args.workers)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
    n = len(frames)
    for i, (read, assemble, parallel) in enumerate(rounds, 1):
        print(
            f"round {i}: read all frames {read:6.2f} s ({1e3 * read / n:5.1f} ms/frame), "
            f"assemble {assemble:6.2f} s ({1e3 * assemble / n:5.1f} ms/frame): "
            f"{assemble / read:4.2f}x; read on {workers} threads {parallel:6.2f} s"
        )
    ratios = sorted(assemble / read for read, assemble, _ in rounds)
    print(
        f"assembly / reading: median {statistics.median(ratios):4.2f}x "
        f"(range {ratios[0]:4.2f}-{ratios[-1]:4.2f}x over {len(ratios)} rounds; target <= 3x)"
    )
    # The assembly reads on all its threads; for comparison, the same read done that way.
    parallel = statistics.median(assemble / p for _, assemble, p in rounds)
    print(f"assembly / reading on {workers} threads: median {parallel:4.2f}x")
    print(f"first assembly in this process (compiles the kernels): {first:8.2f} s")
    print(
        f"peak traced memory {peak / 2**20:8.1f} MiB; all frames {size / 2**20:8.1f} MiB; "
        f"cube {scan.cube.nbytes / 2**20:8.1f} MiB"
    )


def _read_all(session: Session, frames: list[int], threads: int = 1) -> tuple[float, int]:
    """Seconds to read every frame from the store (one after another, or on ``threads``
    threads), and their bytes."""
    start = time.perf_counter()
    if threads == 1:
        size = sum(session.read_frame(i).nbytes for i in frames)
    else:
        with ThreadPoolExecutor(max_workers=threads) as pool:
            size = sum(pool.map(lambda i: session.read_frame(i).nbytes, frames))
    return time.perf_counter() - start, size


def _capture(rig, every: int, data: str) -> Session:
    """A ColorChecker pinhole scan (every n-th frame) captured into ``data``."""
    plan = scan_plan(rig.slm.shape, "led", 0.1, scene="colorchecker", closed_check=False)
    if every > 1:
        plan = Plan(plan.name, plan.steps[::every], plan.parameters)
    session = Session.create(rig.description, plan, session_id="bench", data=data)
    start = time.perf_counter()
    run_plan(rig, plan, session, progress=True)
    print(f"capture (rendering) of {len(plan)} frames: {time.perf_counter() - start:.1f} s")
    return session


if __name__ == "__main__":
    main()
