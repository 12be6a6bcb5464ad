"""How fast ``sassi-bench`` answers when it has nothing to compute.

``sassi-bench --help``, ``--version``, a subcommand's ``--help`` and an argument error
are timed as fresh processes (the console script, as a user runs it), median of
``--repeat`` runs, against a baseline measured in the same run: a Python interpreter that
does nothing (``python -c pass``), the floor no command line can go under. The goal of
the issue that made the command modules import lazily: each answers in under 0.5 s.
Wall time depends on what else the machine runs, so the CPU time the process used (user
plus system, its children included) is printed beside it; on a busy machine judge by it.

Run: ``python benchmarks/bench_cli_startup.py [--repeat 15]``
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

GOAL_S = 0.5
SCRIPT = Path(sys.executable).with_name("sassi-bench")
CASES = {
    "--help": ["--help"],
    "--version": ["--version"],
    "scan --help": ["scan", "--help"],
    "argument error": ["scan", "--bogus"],
}


def _cpu_seconds() -> float:
    used = resource.getrusage(resource.RUSAGE_CHILDREN)
    return used.ru_utime + used.ru_stime


def _median_seconds(argv: list[str], repeat: int) -> tuple[float, float]:
    """Median wall and CPU seconds of ``repeat`` runs."""
    wall, cpu = [], []
    for _ in range(repeat):
        start, start_cpu = time.perf_counter(), _cpu_seconds()
        subprocess.run(argv, capture_output=True, check=False)
        wall.append(time.perf_counter() - start)
        cpu.append(_cpu_seconds() - start_cpu)
    return statistics.median(wall), statistics.median(cpu)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    baseline, baseline_cpu = _median_seconds([sys.executable, "-c", "pass"], args.repeat)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{os.cpu_count()} CPUs, load average {load:.1f}; median of {args.repeat} runs")
    print(f"{'':28s} {'wall':>7s} {'CPU':>7s}")
    print(f"{'baseline (python -c pass)':28s} {baseline:6.3f}s {baseline_cpu:6.3f}s")
    worst = worst_cpu = 0.0
    for name, argv in CASES.items():
        seconds, cpu = _median_seconds([str(SCRIPT), *argv], args.repeat)
        worst, worst_cpu = max(worst, seconds), max(worst_cpu, cpu)
        ratios = f"{seconds / baseline:4.1f}x baseline wall, {cpu / baseline_cpu:4.1f}x CPU"
        print(f"sassi-bench {name:16s} {seconds:6.3f}s {cpu:6.3f}s  ({ratios})")
    verdict = "met" if worst < GOAL_S else "NOT met"
    print(f"goal: every case under {GOAL_S} s: {verdict} (slowest {worst:.3f} s wall, "
          f"{worst_cpu:.3f} s CPU)")  # fmt: skip
    return 0 if worst < GOAL_S else 1


if __name__ == "__main__":
    sys.exit(main())
