"""Batch assembly on a local dask cluster against the serial path, and the cost per task.

Captures one thin pinhole scan of the ColorChecker (every ``--every``-th offset) and copies
it into ``--n`` sessions (assembly costs the same whatever the scene; copying saves the
rendering). Then, in each of ``--rounds`` rounds:

* **serial**: every session assembled and written one after another, as ``sassi-bench
  scan`` does (each assembly on a thread per CPU);
* **batch**: the same sessions as one ``run_batch`` on a ``LocalCluster`` of ``--workers``
  single-threaded worker processes, into a fresh output folder.

The cluster is started once (its start-up and the workers' first compilation of the
kernels are timed apart, as "cold"); the speed-up is the round's serial time over its
batch time, measured side by side because the machine may be shared (ratios of timings
taken together are steadier than absolute times). The per-task overhead is given two
ways: the engine's own (submit and gather ``--n`` trivial tasks) and the batch's
(wall time x workers / sessions, minus the mean time a task spends inside the assembly:
scheduling, loading the bundle on the worker, hashing inputs and output, the atomic
write). Bytes read and written per session, over the batch's time, are what the shared
store must deliver.

A bundle is needed: ``--bundle PATH``, or the spectral calibration runs first.

Run: ``python benchmarks/bench_batch.py [--n 8] [--every 25] [--workers N] [--rounds 3]
[--bundle DIR]``
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import tempfile
import time
from pathlib import Path

from _bundle import bundle_for

from sassi_bench import open_rig
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.batch import run_batch
from sassi_bench.batch.engine import batch_client, default_workers
from sassi_bench.batch.tasks import scan_dataset
from sassi_bench.spectra.cube_io import write_netcdf
from sassi_bench.storage.inventory import folder_size


def _capture(rig, every: int, data: Path) -> Session:
    full = scan_plan(rig.slm.shape, "led", 0.1, scene="colorchecker")
    keep = [s for i, s in enumerate(full.steps) if s.tags["role"] == "closed" or i % every == 1]
    plan = Plan(full.name, tuple(keep), full.parameters)
    session = Session.create(rig.description, plan, session_id="bench-0", data=data)
    run_plan(rig, plan, session, progress=False)
    return session


def _serial(ids: list[str], bundle, data: Path, out: Path) -> float:
    out.mkdir()
    start = time.perf_counter()
    for s in ids:
        write_netcdf(scan_dataset(Session.open(s, data=data), bundle), out / f"{s}.nc")
    return time.perf_counter() - start


def _noop(i: int) -> int:
    return i


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", default="sim")
    parser.add_argument("--n", type=int, default=8, help="sessions in the batch")
    parser.add_argument("--every", type=int, default=25, help="keep every n-th scan frame")
    parser.add_argument("--workers", type=int, default=default_workers())
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--bundle", help="bundle folder for the rig (default: calibrate first)")
    args = parser.parse_args()

    root = Path(tempfile.mkdtemp(prefix="bench-batch-"))
    data = root / "data"
    rig = open_rig(args.rig)
    bundle = bundle_for(rig, args.bundle, str(data))
    first = _capture(rig, args.every, data)
    ids = [first.id]
    for i in range(1, args.n):
        shutil.copytree(first.path, data / "sessions" / f"bench-{i}")
        ids.append(f"bench-{i}")
    frames = len(first.completed) - 1
    session_bytes, _ = folder_size(first.path)
    mb = session_bytes / 1e6
    print(f"{args.n} sessions of {frames} frames ({mb:.1f} MB each), rig {rig.description.name}")

    start = time.perf_counter()
    with batch_client(workers=args.workers) as client:
        started = time.perf_counter() - start
        print(f"cluster of {args.workers} workers up in {started:.1f} s; {client.dashboard_link}")
        start = time.perf_counter()
        cold = run_batch("assemble", ids, bundle, root / "cold", data=data, client=client,
                         progress=False)  # fmt: skip
        print(f"cold batch (workers compile the kernels): {time.perf_counter() - start:.1f} s")
        _serial(ids[:1], bundle, data, root / "warm-serial")  # compile here too

        start = time.perf_counter()
        client.gather(client.map(_noop, range(args.n), pure=False))
        engine = (time.perf_counter() - start) / args.n

        rows = []
        for r in range(args.rounds):
            serial = _serial(ids, bundle, data, root / f"serial-{r}")
            start = time.perf_counter()
            batch = run_batch("assemble", ids, bundle, root / f"batch-{r}", data=data,
                              client=client, progress=False)  # fmt: skip
            wall = time.perf_counter() - start
            assert not batch.failed, batch.failed
            inside = statistics.mean(x.seconds for x in batch.results)
            overhead = wall * args.workers / args.n - inside
            rows.append((serial, wall, serial / wall, inside, overhead))
            print(
                f"round {r}: serial {serial:6.2f} s, batch {wall:6.2f} s, speed-up "
                f"{serial / wall:4.2f}x; task {inside:5.2f} s inside, {overhead:+5.2f} s around"
            )
    cube_bytes = (root / "batch-0" / f"{ids[0]}.nc").stat().st_size
    assert not cold.failed
    speedup = statistics.median(r[2] for r in rows)
    wall = statistics.median(r[1] for r in rows)
    print(f"\nmedian speed-up on {args.workers} workers: {speedup:.2f}x (same-run ratio)")
    print(f"per-task overhead: engine {engine * 1e3:.1f} ms (trivial task round trip), batch "
          f"{statistics.median(r[4] for r in rows):.2f} s per session "
          f"(wall x workers / sessions - time inside the task)")  # fmt: skip
    print(
        f"store traffic: {session_bytes / 1e6:.1f} MB read + {cube_bytes / 1e6:.1f} MB written "
        f"per session, {args.n * (session_bytes + cube_bytes) / wall / 1e6:.1f} MB/s over the "
        "batch"
    )
    print("the machine may be shared: compare ratios from the same run only")
    shutil.rmtree(root)


if __name__ == "__main__":
    main()
