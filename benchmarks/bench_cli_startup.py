"""How fast ``sassi-bench`` answers when it has nothing to compute.

``sassi-bench --help``, ``--version``, a subcommand's ``--help`` and an argument error
are timed as fresh processes (the console script, as a user runs it), median of
``--repeat`` runs, against a baseline measured in the same run: a Python interpreter that
does nothing (``python -c pass``), the floor no command line can go under. The goal of
the issue that made the command modules import lazily: each answers in under 0.5 s.

Run: ``python benchmarks/bench_cli_startup.py [--repeat 15]``
"""

from __future__ import annotations

import argparse
import os
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


def _median_seconds(argv: list[str], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        subprocess.run(argv, capture_output=True, check=False)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeat", type=int, default=15)
    args = parser.parse_args()
    baseline = _median_seconds([sys.executable, "-c", "pass"], args.repeat)
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"{os.cpu_count()} CPUs, load average {load:.1f}; median of {args.repeat} runs")
    print(f"{'baseline (python -c pass)':28s} {baseline:6.3f} s")
    worst = 0.0
    for name, argv in CASES.items():
        seconds = _median_seconds([str(SCRIPT), *argv], args.repeat)
        worst = max(worst, seconds)
        print(f"sassi-bench {name:16s} {seconds:6.3f} s  ({seconds / baseline:4.1f}x baseline)")
    verdict = "met" if worst < GOAL_S else "NOT met"
    print(f"goal: every case under {GOAL_S} s: {verdict} (slowest {worst:.3f} s)")
    return 0 if worst < GOAL_S else 1


if __name__ == "__main__":
    sys.exit(main())
