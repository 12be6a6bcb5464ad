"""What checking every stored frame as it is read costs: a checked read against the same
read unchecked, in the same run, alternated session by session.

For each session under ``DATA`` (e.g. a ``bench_chain.py --data DIR`` run), every frame
is read back twice per round, alternately through :meth:`Session.read_frame` (decoded and
checked against the checksum its event recorded) and straight from the Zarr array (what a
read was before the check), and the CPU time per frame of each is kept; the checksum alone
is timed too. Prints per session and overall: frames, the frame size, milliseconds per
frame unchecked and checked, and their ratio (median over rounds).

Run: ``python benchmarks/bench_frame_check.py DATA [--rounds 3]``
"""

from __future__ import annotations

import argparse
import statistics
import time
import warnings
from pathlib import Path


def _sessions(root: Path) -> list[Path]:
    return sorted(p.parent for p in root.rglob("session.json") if "damaged" not in p.parts)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("data", help="a data root with sessions")
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    import numpy as np

    from sassi_bench.acquire.session import Session, SessionWarning, frame_checksum

    rows, totals = [], {"raw": [], "checked": [], "checksum": []}
    for folder in _sessions(Path(args.data)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SessionWarning)
            session = Session.open(folder)
        steps = sorted(session.completed)
        if not steps:
            continue
        arrays = {
            i: (session._frames.array(session.plan.steps[i].camera), session._log.slots[i][1])
            for i in steps
        }
        times = {"raw": [], "checked": [], "checksum": []}
        for _ in range(args.rounds):
            start = time.process_time()
            for i in steps:
                array, slot = arrays[i]
                np.asarray(array[slot])
            times["raw"].append((time.process_time() - start) / len(steps))
            start = time.process_time()
            frames = [session.read_frame(i) for i in steps[:1]]
            for i in steps:
                session.read_frame(i)
            times["checked"].append((time.process_time() - start) / len(steps))
            start = time.process_time()
            for _ in steps:
                frame_checksum(frames[0])
            times["checksum"].append((time.process_time() - start) / len(steps))
        median = {k: statistics.median(v) for k, v in times.items()}
        for key in totals:
            totals[key].append((median[key], len(steps)))
        megabytes = frames[0].nbytes / 1e6
        rows.append((folder.name, len(steps), megabytes, median))
    print(f"{'session':48s} {'frames':>6s} {'MB':>5s} {'raw ms':>7s} {'checked ms':>10s} "
          f"{'ratio':>6s} {'checksum ms':>11s}")  # fmt: skip
    for name, count, megabytes, m in rows:
        print(
            f"{name[-48:]:48s} {count:6d} {megabytes:5.1f} {1e3 * m['raw']:7.2f} "
            f"{1e3 * m['checked']:10.2f} {m['checked'] / m['raw']:6.3f} "
            f"{1e3 * m['checksum']:11.2f}"
        )
    frames = sum(n for _, n in totals["raw"])
    mean = {k: sum(t * n for t, n in v) / frames for k, v in totals.items()}
    print(
        f"all {frames} frames: raw {1e3 * mean['raw']:.2f} ms, checked "
        f"{1e3 * mean['checked']:.2f} ms a frame (x{mean['checked'] / mean['raw']:.3f}); "
        f"the checksum alone {1e3 * mean['checksum']:.2f} ms"
    )


if __name__ == "__main__":
    main()
