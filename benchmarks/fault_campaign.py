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

``--damage`` is the failing disk instead: each round, in a fresh copy of the lab, one
stored file of the finished results (a session's frame chunk, header, event log or frame
store metadata; a published bundle's file) chosen at random is deleted, truncated at a
random length or has one random byte flipped. Then every command that reads that file
runs (``DAMAGE_READERS``), and each must either name the file (a non-zero exit whose
message holds its name, nothing written under its output's name, no traceback) or
recover (exit 0 with the result it gives on the undamaged lab: the same arrays; a capture
that takes a damaged frame again says so). A command that ends 0 with another result than
the undamaged lab's computed it from damaged data: that is the failure this looks for.

Run: ``python benchmarks/fault_campaign.py [--rounds 5] [--seed 0] [--bundle DIR]
[--case NAME ...] [--damage]`` (``--bundle``: a published sim bundle with a guide
homography, e.g. from ``sassi-bench calibrate``; without it one is calibrated first, with
the bench's true homography).
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


# -- disk damage ---------------------------------------------------------------------------

#: The commands that read each group of stored files (``{out}`` a fresh folder per run),
#: with the output to compare with the undamaged lab's (None: the command writes none).
#: ``world-scan`` is a ColorChecker scan, ``world-snap`` a one-frame snapshot, ``bundle``
#: the published bundle (``fault_kit.build_world``).
DAMAGE_READERS = {
    "world-scan": (
        ("scan (resumed)", ("scan", "--rig", "sim", "--session", "world-scan", "--out",
                            "{out}/cube.nc", "--quiet"), "cube.nc"),
        ("batch assemble", ("batch", "assemble", "--sessions", "world-scan", "--out",
                            "{out}/cubes", "--workers", "1", "--quiet"), "cubes/world-scan.nc"),
        ("data verify", ("data", "verify", "world-scan", "--quiet"), None),
    ),
    "world-snap": (
        ("snapshot reconstruct", ("snapshot", "reconstruct", "--session", "world-snap",
                                  "--out", "{out}/rec", "--no-envi", "--quiet"), "rec"),
        ("data verify", ("data", "verify", "--quiet"), None),
    ),
    "bundle": (
        ("bundle verify", ("bundle", "verify", "v0001"), None),
        ("bundle show", ("bundle", "show", "v0001"), None),
        ("batch assemble", ("batch", "assemble", "--sessions", "world-scan", "--out",
                            "{out}/cubes", "--workers", "1", "--quiet"), "cubes/world-scan.nc"),
    ),
}  # fmt: skip
DAMAGES = ("delete", "truncate", "flip")
#: Files that hold no result (locks, a check's own record).
_NOT_RESULTS = ("write.lock", "verify.json")


def _group(path: Path, data: Path) -> str | None:
    """Which readers' group a stored file belongs to (None: no reader is listed)."""
    parts = path.relative_to(data).parts
    if parts[0] == "sessions" and parts[1] == "world-scan":
        return "world-scan"
    if parts[0] == "sessions" and parts[1].startswith("world-snap"):
        return "world-snap"
    if parts[:2] == ("sim", "v0001"):
        return "bundle"
    return None


def damage_targets(data: Path) -> list[Path]:
    """The stored files of the finished results that a listed command reads."""
    return sorted(
        p for p in data.rglob("*")
        if p.is_file() and p.name not in _NOT_RESULTS and _group(p, data) is not None
    )  # fmt: skip


def damage(path: Path, how: str, rng: random.Random) -> str:
    """Damage one file as a failing disk would; what was done, in words."""
    raw = path.read_bytes()
    if how == "delete" or not raw:
        path.unlink()
        return "deleted"
    if how == "truncate":
        keep = rng.randrange(len(raw))
        path.write_bytes(raw[:keep])
        return f"truncated to {keep} of {len(raw)} bytes"
    at = rng.randrange(len(raw))
    flipped = bytearray(raw)
    flipped[at] ^= 1 << rng.randrange(8)
    path.write_bytes(bytes(flipped))
    return f"byte {at} of {len(raw)} flipped"


def _arrays(path: Path) -> dict[str, object]:
    """The arrays of an output (NetCDF variables, every .nc of a folder), for comparing."""
    import xarray as xr

    files = sorted(path.rglob("*.nc")) if path.is_dir() else [path]
    found = {}
    for file in files:
        with xr.open_dataset(file) as ds:
            for name, variable in ds.data_vars.items():
                found[f"{file.name}:{name}"] = variable.values
    return found


def _same(a: dict, b: dict) -> bool:
    import numpy as np

    return a.keys() == b.keys() and all(np.array_equal(a[k], b[k], equal_nan=True) for k in a)


def _names(text: str, path: Path, data: Path) -> bool:
    """Whether a command's words name the damaged file (its path in the session or
    bundle, or its file name for one that is not a frame chunk)."""
    rel = path.relative_to(data)
    inner = Path(*rel.parts[2:]).as_posix()  # frames.zarr/spectral/c/3/0/0, session.json
    return inner in text or ("/c/" not in inner and path.name in text)


def damage_round(template: Path, into: Path, rng: random.Random, baseline: dict) -> list[str]:
    """One round: a random stored file damaged, every command reading it run and judged.
    Prints one line per command; returns the problems."""
    damaged = into / "damaged"  # the lab with the damage, copied for each command
    shutil.copytree(template, damaged)
    stored = damaged / "data"
    chosen = rng.choice(damage_targets(stored))
    group = _group(chosen, stored)
    what = damage(chosen, rng.choice(DAMAGES), rng)
    print(f"  {chosen.relative_to(stored)}: {what}")
    problems = []
    for name, argv, output in DAMAGE_READERS[group]:
        # each command meets the damage as the disk left it (a capture repairs it)
        places = kit.fresh_lab(damaged, into / "".join(c if c.isalnum() else "-" for c in name))
        data, out = places["data"], places["out"]
        target = data / chosen.relative_to(stored)
        run = kit.run_command(kit.fill(argv, places), data, timeout=1800)
        text = run.stdout + run.stderr
        if "Traceback" in run.stderr:
            verdict = "PROBLEM: a traceback"
        elif run.returncode not in (0, 1, 2):
            verdict = f"PROBLEM: exit {run.returncode}"
        elif run.returncode != 0:
            written = output is not None and (out / output).exists()
            named = _names(text, target, data)
            verdict = (
                "named it"
                if named and not written
                else "PROBLEM: " + ("wrote its output" if written else "did not name it")
            )
        elif output is None:
            seen = name == "data verify" and "/c/" in target.as_posix()
            verdict = "PROBLEM: a damaged frame passed" if seen else "unaffected"
        elif not _same(_arrays(out / output), baseline[(group, name)]):
            verdict = "PROBLEM: a result computed from damaged data"
        else:
            verdict = "recovered" if "captured again" in run.stderr else "unaffected"
        print(f"    {name:22s} exit {run.returncode}: {verdict}")
        if verdict.startswith("PROBLEM"):
            problems.append(f"{chosen.relative_to(stored)} ({what}): {name}: {verdict[9:]}")
    return problems


def run_damage(template: Path, work: Path, rounds: int, rng: random.Random, keep: bool) -> int:
    """The disk-damage campaign; exit status 1 if anything was found."""
    baseline = {}
    for group, readers in DAMAGE_READERS.items():
        for name, argv, output in readers:
            if output is None:
                continue
            into = work / f"baseline-{group}-{name.split()[0]}"
            places = kit.fresh_lab(template, into)
            out = places["out"]
            run = kit.run_command(kit.fill(argv, places), places["data"], timeout=1800)
            if run.returncode != 0:
                print(f"baseline {name} failed: {run.stderr.strip().splitlines()[-1:]}")
                return 1
            baseline[(group, name)] = _arrays(out / output)
            shutil.rmtree(into, ignore_errors=True)
    problems = []
    for k in range(rounds):
        print(f"round {k + 1}:")
        into = work / f"damage-{k}"
        found = damage_round(template, into, rng, baseline)
        problems += found
        if not found and not keep:
            shutil.rmtree(into, ignore_errors=True)
    print(f"\n{rounds} damaged files, {len(problems)} problems")
    for problem in problems:
        print(f"  {problem}")
    return 1 if problems else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5, help="kill points per command")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--bundle", help="a sim bundle folder with a guide homography")
    parser.add_argument("--case", action="append", choices=sorted(kit.CASES))
    parser.add_argument("--keep", action="store_true", help="keep the work folder")
    parser.add_argument(
        "--damage", action="store_true", help="damage stored files instead of killing commands"
    )
    args = parser.parse_args()
    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="sassi-faults-"))
    print(f"work folder {work}")
    bundle = Path(args.bundle) if args.bundle else _guided_bundle(work)
    template = work / "template"
    kit.build_world(template, bundle)
    if args.damage:
        status = run_damage(template, work, args.rounds, rng, args.keep)
        if not args.keep and status == 0:
            shutil.rmtree(work, ignore_errors=True)
        return status
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
