"""The whole calibration chain, stage by stage: frames, time, rendering, memory.

Runs ``sassi-bench calibrate`` (``run_full_calibration`` with the shipped procedures) on a
virtual rig and prints one row per stage:

* **frames**: frames the stage stored (for the fits, the frames they read back);
* **wall s / CPU s**: the stage's wall time and the process's CPU time (all threads);
* **render**: the virtual bench's share (electron rates, sensor noise, scene builds:
  the cost a real bench does not have, which streams frames at the SLM's rate);
* **store**: writing frames to their session (compression, hash, fsync);
* **compile**: numba compiling the compiled loops, once per process on first use (in
  whichever stage uses a kernel first; a lab's long-running process pays it once);
* **process**: the rest, the procedure's own work;
* **read ms**: reading one of the stage's frames back from its session (the stage's
  sessions are read once more at the end of the run, frame by frame, in the same run);
* **process/read**: processing per frame over that read time (the goal is at most 1.5);
* **peak GB**: the process's peak resident memory during the stage.

Render, store, process and read are CPU seconds (all threads), so the split and the
ratio hold on a busy machine, where wall time is mostly waiting for a core (the load
average at the start and end is printed); the wall column is this run's. Frames are
processed while they are captured (decoded, or taken by a scan's reading pass) on
worker threads: their CPU time during a render or a store is processing, and is taken
out of those columns. Given ``--data`` of an earlier run, the chain resumes from its
sessions: nothing is rendered or stored, and the table shows the processing alone
against reading back the frames each stage read. ``--accuracy``
runs the chain with the accuracy table's procedure (``benchmarks/accuracy_table.py``,
laser wavelengths estimated) and prints the table's column for the rig, scored against
the bench's truth, so one run gives both.

Writes the table and the run's disk use to ``docs/_data/chain_<rig>.json`` (with the date,
the machine and the command), which the performance page quotes, unless ``--no-update``.

Run: ``python benchmarks/bench_chain.py [--rig sim-prototype] [--data DIR] [--accuracy]``
(``--rig sim`` takes about two minutes on two quiet cores; ``sim-prototype`` about five).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import importlib
import os
import shutil
import sys
import tempfile
import threading
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

STAGES = (
    "grey response",
    "sweeps and decoding",
    "dispersion and blur fits",
    "response scan",
    "guide scan and registration",
    "Macbeth scan and validation",
    "publishing",
)
# (module, function, stage): calling the function enters the stage until it returns.
MARKERS = (
    ("sassi_bench.workflows.full", "run_spectral_calibration", "sweeps and decoding"),
    ("sassi_bench.workflows.full", "run_response", "response scan"),
    ("sassi_bench.workflows.full", "run_guide_registration", "guide scan and registration"),
    ("sassi_bench.workflows.full", "run_macbeth", "Macbeth scan and validation"),
    ("sassi_bench.workflows.full", "render_report", "Macbeth scan and validation"),
    ("sassi_bench.workflows.full", "publish_derived", "publishing"),
    ("sassi_bench.workflows.spectral", "measure_response", "grey response"),
    ("sassi_bench.workflows.spectral", "analyse_spectral_sweeps", "dispersion and blur fits"),
    ("sassi_bench.workflows.spectral", "render_figures", "dispersion and blur fits"),
    ("sassi_bench.workflows.spectral", "publish_spectral", "publishing"),
    ("sassi_bench.reduce.spectral", "measure_response", "grey response"),
    ("sassi_bench.reduce.sweeps", "_structured_decode", "sweeps and decoding"),
    ("sassi_bench.reduce.sweeps", "_line_decode", "sweeps and decoding"),
    ("sassi_bench.reduce.response", "publish_derived", "publishing"),
    ("sassi_bench.reduce.guide", "publish_derived", "publishing"),
)


def _status(key: str) -> int:
    """A /proc/self/status field in bytes (VmRSS, VmHWM)."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(key + ":"):
                return int(line.split()[1]) * 1024
    return 0


def _reset_peak() -> None:
    """Start a new resident-memory high-water mark (Linux: clear_refs 5)."""
    with contextlib.suppress(OSError), open("/proc/self/clear_refs", "w") as refs:
        refs.write("5")


class StageClock:
    """Wall, CPU and peak memory per stage; the stage is the innermost marker entered."""

    def __init__(self) -> None:
        self.stack = ["setup"]
        self.wall: dict[str, float] = defaultdict(float)
        self.cpu: dict[str, float] = defaultdict(float)
        self.peak: dict[str, int] = defaultdict(int)
        self.render: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
        self.compile: dict[str, float] = defaultdict(float)
        self.store: dict[str, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
        self.reads: dict[str, set[str]] = defaultdict(set)
        self.frames_read: dict[str, int] = defaultdict(int)
        self.written: dict[str, str] = {}  # session id -> stage that wrote it
        self._mark = (time.perf_counter(), time.process_time())
        self._main = threading.main_thread()
        _reset_peak()

    @property
    def stage(self) -> str:
        return self.stack[-1]

    def _switch(self) -> None:
        now = (time.perf_counter(), time.process_time())
        stage = self.stage
        self.wall[stage] += now[0] - self._mark[0]
        self.cpu[stage] += now[1] - self._mark[1]
        self.peak[stage] = max(self.peak[stage], _status("VmHWM"))
        _reset_peak()
        self._mark = now

    @contextlib.contextmanager
    def entered(self, stage: str):
        if threading.current_thread() is not self._main:
            yield
            return
        self._switch()
        self.stack.append(stage)
        try:
            yield
        finally:
            self._switch()
            self.stack.pop()

    def wrap(self, function, stage: str):
        @functools.wraps(function)
        def marked(*args, **kwargs):
            with self.entered(stage):
                return function(*args, **kwargs)

        return marked

    def finish(self) -> None:
        """End the timing; later reads (the read-back) count to no stage."""
        self._switch()
        self.stack.append("read back")


#: Threads of zarr's I/O loop and its executor, which compress and write the chunks.
_ZARR_THREADS = ("zarr_io", "asyncio_")


def _storing_threads() -> tuple[str, ...]:
    """Name prefixes of the threads that store frames: the capture's writer and zarr's."""
    from sassi_bench.acquire.runner import WRITER_THREAD_PREFIX

    return (WRITER_THREAD_PREFIX, *_ZARR_THREADS)


def _background_threads() -> tuple[str, ...]:
    """Name prefixes of a capture's background threads: the workers that process frames
    as they are stored (:mod:`sassi_bench.acquire.frame_feed`) and the storing ones."""
    from sassi_bench.acquire.frame_feed import THREAD_PREFIX

    return (THREAD_PREFIX, *_storing_threads())


def _thread_cpu(prefixes: tuple[str, ...]) -> dict[int, float]:
    """CPU seconds so far of every thread whose name starts with one of ``prefixes``."""
    out = {}
    for thread in threading.enumerate():
        if thread.name.startswith(prefixes) and thread.ident is not None:
            with contextlib.suppress(OSError):  # the thread ended meanwhile
                out[thread.ident] = time.clock_gettime(time.pthread_getcpuclockid(thread.ident))
    return out


def _spent(start: dict[int, float], now: dict[int, float]) -> float:
    return sum(value - start.get(ident, 0.0) for ident, value in now.items())


def _cpu_mark() -> tuple[float, dict[int, float]]:
    """Process CPU time and the background threads' CPU, now."""
    return time.process_time(), _thread_cpu(_background_threads())


def _cpu_besides_feeds(start: tuple[float, dict[int, float]]) -> float:
    """Process CPU since ``start`` (process time and the background threads' CPU), less
    what the capture's background threads spent meanwhile: while the bench renders, a
    worker may be processing an earlier frame (processing) and the writer and zarr storing
    one (storing)."""
    cpu = time.process_time() - start[0]
    return cpu - _spent(start[1], _thread_cpu(_background_threads()))


#: Threads inside a bench call: a compilation there is the bench's (rendering) cost.
_RENDERING = threading.local()


def _time_compiles(clock: StageClock) -> None:
    """Count numba's compilations apart: kernels compile once per process, on first use,
    whichever stage that is (the compiling thread's CPU, outermost compilation only; the
    virtual bench's own kernels, compiled inside a render, count to the render)."""
    from numba.core.dispatcher import Dispatcher

    compile_for_args = Dispatcher._compile_for_args
    depth = threading.local()

    def timed(self, *args, **kwargs):
        if getattr(depth, "value", 0) or getattr(_RENDERING, "active", False):
            return compile_for_args(self, *args, **kwargs)
        depth.value = 1
        start = time.thread_time()
        try:
            return compile_for_args(self, *args, **kwargs)
        finally:
            depth.value = 0
            clock.compile[clock.stage] += time.thread_time() - start

    Dispatcher._compile_for_args = timed


def instrument(clock: StageClock, rig) -> None:
    """Put the stage markers and the bench, store and read timers in place."""
    from sassi_bench.acquire.session import Session

    for module_name, name, stage in MARKERS:
        module = importlib.import_module(module_name)
        if hasattr(module, name):
            setattr(module, name, clock.wrap(getattr(module, name), stage))
        else:
            print(f"note: {module_name}.{name} not found; its time counts to its caller")

    _time_compiles(clock)
    capture = importlib.import_module("sassi_bench.workflows.spectral")
    run_plan = capture.run_plan

    def run_stage_plan(rig, plan, session, **kwargs):
        if not session.id.endswith("-grey"):
            return run_plan(rig, plan, session, **kwargs)
        with clock.entered("grey response"):
            return run_plan(rig, plan, session, **kwargs)

    capture.run_plan = run_stage_plan

    def timed_render(function):
        @functools.wraps(function)
        def rendering(*args, **kwargs):
            wall, start = time.perf_counter(), _cpu_mark()
            nested = getattr(_RENDERING, "active", False)
            _RENDERING.active = True
            try:
                return function(*args, **kwargs)
            finally:
                _RENDERING.active = nested
                entry = clock.render[clock.stage]
                entry[0] += time.perf_counter() - wall
                entry[1] += _cpu_besides_feeds(start)
                entry[2] += 1

        return rendering

    for camera in (rig.spectral_camera, rig.guide_camera):
        camera._expose = timed_render(camera._expose)
    # Scene builds are the bench's cost too; the rig calls the bench's method it was
    # built with, so the rig's setter is the one to time.
    object.__setattr__(rig, "scene_setter", timed_render(rig.scene_setter))

    write_frame, read_frame, read_frames = (
        Session.write_frame,
        Session.read_frame,
        Session.read_frames,
    )

    def write(self, step_index, frame):
        # Frames are stored on the capture's writer thread (zarr compressing on its own)
        # while the bench renders the next: those threads' CPU is the store's.
        wall, start = time.perf_counter(), _thread_cpu(_storing_threads())
        try:
            return write_frame(self, step_index, frame)
        finally:
            entry = clock.store[clock.stage]
            entry[0] += time.perf_counter() - wall
            entry[1] += _spent(start, _thread_cpu(_storing_threads()))
            entry[2] += 1
            clock.written.setdefault(self.id, clock.stage)

    def read(self, step_index):
        clock.reads[clock.stage].add(self.id)
        clock.frames_read[clock.stage] += 1
        return read_frame(self, step_index)

    def read_many(self, step_indices):
        indices = list(step_indices)
        clock.reads[clock.stage].add(self.id)
        clock.frames_read[clock.stage] += len(indices)
        return read_frames(self, indices)

    Session.write_frame, Session.read_frame, Session.read_frames = write, read, read_many


def read_back(sessions: dict[str, Path]) -> dict[str, float]:
    """CPU seconds to read one frame back from each session, frame by frame (all frames)."""
    import numpy as np

    from sassi_bench.acquire.session import Session

    per_frame = {}
    for session_id, data in sessions.items():
        session = Session.open(session_id, data=data)
        steps = sorted(session.completed)
        start = time.process_time()
        for frame in session.iter_frames(steps):
            np.asarray(frame)
        per_frame[session_id] = (time.process_time() - start) / max(len(steps), 1)
    return per_frame


def table_rows(clock: StageClock, read_s: dict[str, float]) -> tuple[list[str], list[list[str]]]:
    """The per-stage table: its header and one row per stage, the whole chain last."""
    header = [
        "stage", "frames", "wall s", "CPU s", "render CPU s", "store CPU s",
        "compile CPU s", "process CPU s", "read CPU ms", "process/read", "peak GB",
    ]  # fmt: skip
    rows = []
    totals = defaultdict(float)
    for stage in ("setup", *STAGES):
        if stage not in clock.wall:
            continue
        wall, cpu = clock.wall[stage], clock.cpu[stage]
        _, render, _ = clock.render[stage]
        _, store, stored = clock.store[stage]
        compiled = clock.compile[stage]
        process = cpu - render - store - compiled
        sessions = [s for s, st in clock.written.items() if st == stage] or sorted(
            clock.reads[stage]
        )
        frames = int(stored) if stored else clock.frames_read[stage]
        reads = [read_s[s] for s in sessions if s in read_s]
        read = sum(reads) / len(reads) if reads else float("nan")
        ratio = process / frames / read if frames and reads else float("nan")
        rows.append([
            stage, str(frames), f"{wall:.1f}", f"{cpu:.1f}", f"{render:.1f}",
            f"{store:.1f}", f"{compiled:.1f}", f"{process:.1f}",
            f"{1000 * read:.1f}" if reads else "-", f"{ratio:.2f}" if ratio == ratio else "-",
            f"{clock.peak[stage] / 1e9:.2f}",
        ])  # fmt: skip
        for key, value in (
            ("wall", wall), ("cpu", cpu), ("render", render), ("store", store),
            ("compile", compiled),
        ):  # fmt: skip
            totals[key] += value
        totals["frames"] += stored
    peak = max(clock.peak.values())
    process = totals["cpu"] - totals["render"] - totals["store"] - totals["compile"]
    rows.append([
        "whole chain", str(int(totals["frames"])), f"{totals['wall']:.1f}",
        f"{totals['cpu']:.1f}", f"{totals['render']:.1f}", f"{totals['store']:.1f}",
        f"{totals['compile']:.1f}", f"{process:.1f}", "-", "-", f"{peak / 1e9:.2f}",
    ])  # fmt: skip
    return header, rows


def disk_totals(staging: Path) -> tuple[int, int]:
    """Bytes of raw frames left in the staging folder: all of them, and those
    ``keep: audit`` keeps (the grey and sweep frames)."""
    from sassi_bench.storage.inventory import folder_size

    total = audit = 0
    for folder in sorted((staging / "sessions").iterdir()):
        frames = folder / "frames.zarr"
        size = folder_size(frames)[0] if frames.exists() else 0
        total += size
        audit += size if folder.name.endswith(("-spectral-grey", "-spectral-sweep")) else 0
    return total, audit


def update_figures(rig: str, header: list[str], rows: list[list[str]], staging: Path):
    """Write the run's table and its disk use to ``docs/_data/chain_<rig>.json``, the
    figures the performance page quotes."""
    from figures import update_columns

    from sassi_bench.storage.inventory import format_size

    total, audit = disk_totals(staging)
    stages = [row[0] for row in rows]
    columns = [
        {"key": name, "values": {row[0]: row[i] for row in rows}}
        for i, name in enumerate(header[1:], start=1)
    ]
    stages += ["raw frames a run (keep: all)", "raw frames a run (keep: audit)"]
    columns.append(
        {
            "key": "disk",
            "values": {stages[-2]: format_size(total), stages[-1]: format_size(audit)},
        }
    )
    title = f"The whole calibration chain on `{rig}`, stage by stage"
    return update_columns(f"chain_{rig}", title, stages, columns, row_label="stage", replace=True)


def disk_use(staging: Path) -> str:
    """Bytes of raw frames per session left in the staging folder."""
    from sassi_bench.storage.inventory import folder_size, format_size

    lines, total, audit = [], 0, 0
    for folder in sorted((staging / "sessions").iterdir()):
        frames = folder / "frames.zarr"
        size = folder_size(frames)[0] if frames.exists() else 0
        total += size
        audit += size if folder.name.endswith(("-spectral-grey", "-spectral-sweep")) else 0
        lines.append(f"  {folder.name}: {format_size(size)}")
    return "\n".join([
        f"raw frames left by the run: {format_size(total)} (keep: all); "
        f"{format_size(audit)} with keep: audit (grey and sweep frames)",
        *lines,
    ])  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rig", default="sim-prototype")
    parser.add_argument("--data", help="data folder to keep the run in (default: a temporary one)")
    parser.add_argument(
        "--accuracy", action="store_true", help="also score the run against the truth"
    )
    parser.add_argument(
        "--no-update", action="store_true", help="print only: leave docs/_data/chain_<rig>.json"
    )
    args = parser.parse_args()
    print(f"load average at start: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    clock = StageClock()
    from sassi_bench import open_rig
    from sassi_bench._shared.tables import text_table
    from sassi_bench.procedure import load_procedure
    from sassi_bench.workflows.full import run_full_calibration

    rig = open_rig(args.rig)
    instrument(clock, rig)
    with tempfile.TemporaryDirectory(prefix="bench-chain-") as tmp:
        data = Path(args.data) if args.data else Path(tmp)
        data.mkdir(parents=True, exist_ok=True)
        procedure = load_procedure("full_calibration")
        if "keep" in procedure:
            procedure["keep"] = "all"  # every frame stays, to be read back below
        if args.accuracy:
            from accuracy_table import accuracy_procedure

            procedure = accuracy_procedure(procedure, data)
        start = time.perf_counter()
        result = run_full_calibration(
            rig, procedure, session_id="bench-chain", data=data, progress=False,
            allow_failed=True,
        )  # fmt: skip
        chain_wall = time.perf_counter() - start
        clock.finish()
        staging = result.stages["staging"]
        # A resumed run (``--data`` of an earlier run) writes nothing: read back what it read.
        touched = set(clock.written).union(*clock.reads.values())
        read_s = read_back(dict.fromkeys(sorted(touched), staging))
        print(f"\nrig {args.rig}: whole chain {chain_wall:.0f} s wall")
        failed = [c.name for c in result.checks if not c.passed]
        print("all checks pass" if not failed else "FAILED checks: " + ", ".join(failed))
        header, rows = table_rows(clock, read_s)
        print(text_table(header, rows))
        renders = {stage: entry for stage, entry in clock.render.items() if entry[2]}
        print("\nrendering per bench call (camera exposures and scene changes):")
        for stage, (wall, cpu, calls) in renders.items():
            print(
                f"  {stage}: {calls} calls, {1000 * cpu / calls:.0f} ms CPU, "
                f"{1000 * wall / calls:.0f} ms wall each"
            )
        print(disk_use(staging))
        if not args.no_update:
            print(f"wrote {update_figures(args.rig, header, rows, staging)}")
        if args.accuracy:
            from accuracy_table import markdown, score

            print("\n" + markdown([score(rig, result)]))
        if args.data is None:
            shutil.rmtree(staging, ignore_errors=True)
    print(f"load average at end: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
