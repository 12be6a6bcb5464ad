"""Kill every command that writes at random moments, over and over, and check what it leaves.

For each command of ``tests/faults/fault_kit.py`` (every ``sassi-bench`` command that
writes), one uninterrupted run is timed first (its outputs checked whole), then
``--rounds`` kill points: a fresh copy of a lab's data root with earlier results, the
command started, and SIGINT, SIGTERM or SIGKILL (drawn at random) sent after a random
delay (uniform over the uninterrupted run's duration) or after a random number of stored
frames. After each: every earlier result intact and readable, no half-written file under
a final name, the resume printed or recorded; then the run is resumed (the resume
command, or the same command again) to its end and checked again. Prints one line per
kill point and a table per command; exit status 1 if anything was found.

The unit suite (``tests/faults/test_kill_points.py``) runs fixed kill points on the
quicker commands; this is the long version, over every command, run on demand.

Run: ``python benchmarks/fault_campaign.py [--rounds 5] [--seed 0] [--bundle DIR]
[--case NAME ...]`` (``--bundle``: a published sim bundle with a guide homography, e.g.
from ``sassi-bench calibrate``; without it one is calibrated first, with the bench's
true homography).
"""

from __future__ import annotations

import argparse
import random
import shutil
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "faults"))

import fault_kit as kit  # noqa: E402


def _guided_bundle(work: Path) -> Path:
    """A spectral calibration of the sim rig plus the bench's true guide homography."""
    import dataclasses

    from sassi_bench import open_rig
    from sassi_bench.bundle import load, publish
    from sassi_bench.procedure import load_procedure
    from sassi_bench.rig.sim import truth
    from sassi_bench.workflows.spectral import run_spectral_calibration

    rig = open_rig("sim")
    result = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=work / "calibration", progress=False
    )
    spectral = load(result.bundle_path)
    models = dataclasses.replace(
        spectral.models, guide_to_slm=truth(rig).guide_to_slm, guide_info={"source": "truth"}
    )
    return publish(
        models, rig=rig.description, quality={"checks": [], "residuals": {}},
        procedure=dict(spectral.manifest["procedure"]), data=work / "guided",
    )  # fmt: skip


def _roots(places: dict[str, Path]) -> list[Path]:
    return [places["data"], places["out"], places["other"], places["zip"].parent]


def _one(case: kit.Case, template: Path, into: Path, signame: str, trigger: str) -> kit.Outcome:
    places = kit.fresh_lab(template, into)
    argv = kit.fill(case.argv, places)
    roots = _roots(places)
    before = kit.take_snapshot(roots)
    removable = kit.removable_by(case, places["data"])
    outcome = kit.kill_point(case, argv, places["data"], roots, signame, trigger)
    after = kit.check_kill_point(case, outcome, before, roots, places["data"], removable)
    if outcome.killed:
        if case.name in kit.FRESH_OUT:  # it refuses what is there: a fresh folder
            fresh = dict(places, out=places["out"] / "again")
            fresh["out"].mkdir()
            argv = kit.fill(case.argv, fresh)
        outcome.problems += kit.resume(case, outcome, argv, places["data"])
        outcome.problems += kit.check_intact(before, kit.take_snapshot(roots), removable)
        outcome.problems += kit.check_whole(roots)
    del after
    return outcome


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="kill points per command")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--bundle", help="a sim bundle folder with a guide homography")
    parser.add_argument("--case", action="append", choices=sorted(kit.CASES))
    parser.add_argument("--keep", action="store_true", help="keep the work folder")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="sassi-faults-"))
    print(f"work folder {work}")
    bundle = Path(args.bundle) if args.bundle else _guided_bundle(work)
    template = work / "template"
    kit.build_world(template, bundle)
    found: dict[str, list[kit.Outcome]] = defaultdict(list)
    for name in args.case or sorted(kit.CASES):
        case = kit.CASES[name]
        start = time.monotonic()
        first = _one(case, template, work / f"{name}-full".replace(" ", "_"), "SIGTERM",
                     f"seconds:{case.timeout_s}")  # fmt: skip
        duration = time.monotonic() - start
        status = "ok" if not first.problems else "; ".join(first.problems)
        print(f"{name}: uninterrupted {duration:.0f} s, status {first.status}: {status}")
        for k in range(args.rounds):
            signame = rng.choice(sorted(kit.SIGNALS))
            if case.captures and rng.random() < 0.5:
                trigger = f"frames:{rng.randint(1, 40)}"
            else:
                trigger = f"seconds:{rng.uniform(0.2, max(1.0, first.seconds)):.2f}"
            into = work / f"{name}-{k}".replace(" ", "_")
            outcome = _one(case, template, into, signame, trigger)
            found[name].append(outcome)
            verdict = "ok" if not outcome.problems else "PROBLEMS: " + "; ".join(outcome.problems)
            when = "killed" if outcome.killed else "ended first"
            print(f"  {signame:7s} at {trigger:14s} {when:11s} exit {outcome.status}: {verdict}")
            if not outcome.problems and not args.keep:
                shutil.rmtree(into, ignore_errors=True)
    total = sum(len(v) for v in found.values())
    bad = sum(1 for v in found.values() for o in v if o.problems)
    killed = sum(1 for v in found.values() for o in v if o.killed)
    print(f"\n{total} kill points ({killed} landed before the command ended), {bad} with problems")
    for name, outcomes in sorted(found.items()):
        signals = ", ".join(sorted({o.signal for o in outcomes}))
        print(f"  {name:26s} {len(outcomes):3d} points ({signals}), "
              f"{sum(1 for o in outcomes if o.problems)} with problems")  # fmt: skip
    if not args.keep and not bad:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
