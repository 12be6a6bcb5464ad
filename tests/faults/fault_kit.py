"""Interrupt commands that write, and check what they leave.

Shared by the unit suite (``tests/faults/test_kill_points.py``: fixed kill points on the
quicker commands) and the long randomized campaign (``benchmarks/fault_campaign.py``). A *kill
point* is one run of a command, in a fresh process, stopped by SIGINT, SIGTERM or SIGKILL
at a trigger (after N stored frames, once a file appears, or after a delay). After it:

1. every result that was on disk before is intact and readable (files byte for byte;
   sessions keep every frame they had, each re-hashed; bundles verify; ``LATEST`` names
   a published version);
2. no file under a final (not hidden) name is half-written: each opens as what its name
   says (NetCDF, ENVI, PNG, TIFF, JSON, HTML, zip, MAT, CSV, YAML, .npy), every session
   verifies and every bundle verifies;
3. the run says how to resume: a run that left a session incomplete printed the command
   (Ctrl-C, SIGTERM) or recorded it under ``<data>/runs/`` (any signal), and that
   command (or, for a command that captures nothing, the same command again) finishes.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
import warnings
import zipfile
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

PROG = "sassi-bench"
SCRIPT = Path(sys.executable).with_name(PROG)
SIGNALS = {"SIGINT": signal.SIGINT, "SIGTERM": signal.SIGTERM, "SIGKILL": signal.SIGKILL}


@dataclass(frozen=True)
class Case:
    """A command that writes, as a template: ``{data}``, ``{out}``, ``{zip}``,
    ``{other}`` (a second data root) are filled in per run."""

    name: str
    argv: tuple[str, ...]
    captures: bool = False  # it records raw sessions (and so prints a --session resume)
    outputs: tuple[str, ...] = ()  # what a finished run leaves (templates, under {out})
    ok_status: tuple[int, ...] = (0,)  # exit statuses of a finished run (1: a failed check)
    timeout_s: float = 1200.0


@dataclass
class Outcome:
    """What one kill point did."""

    case: str
    signal: str
    trigger: str
    status: int | None
    stdout: str
    stderr: str
    killed: bool  # the signal arrived before the command ended
    seconds: float
    problems: list[str] = field(default_factory=list)
    resumed: str = ""  # the command that resumed it, if run


def fresh_lab(template: Path, into: Path) -> dict[str, Path]:
    """A copy of the template lab, and the places a command template names."""
    shutil.copytree(template, into)
    out = into / "out"
    out.mkdir()
    return {
        "data": into / "data", "zip": into / "earlier" / "world.zip", "out": out,
        "other": into / "other",
    }  # fmt: skip


def fill(template: Sequence[str], places: dict[str, Path]) -> list[str]:
    """A command line from a template."""
    return [part.format(**{k: str(v) for k, v in places.items()}) for part in template]


# -- what is on disk -----------------------------------------------------------------------


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for chunk in iter(lambda: stream.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _hidden(path: Path, root: Path) -> bool:
    return any(part.startswith(".") for part in path.relative_to(root).parts)


def _session_dirs(root: Path) -> list[Path]:
    return sorted(p.parent for p in root.rglob("session.json") if not _hidden(p, root))


def _bundle_dirs(root: Path) -> list[Path]:
    return sorted(
        p.parent
        for p in root.rglob("manifest.sha256")
        if not _hidden(p, root) and (p.parent / "manifest.json").is_file()
    )


def _inside(path: Path, folders: Iterable[Path]) -> bool:
    return any(folder == path or folder in path.parents for folder in folders)


@dataclass
class Snapshot:
    """The files under some roots, sessions by their frames, and bundles, at one time."""

    files: dict[Path, str]
    sessions: dict[Path, dict[int, str]]
    bundles: set[Path]


def _frames(session: Path) -> dict[int, str]:
    from sassi_bench.acquire.session import Session

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        opened = Session.open(session)
    return {i: opened.event(i)["sha256"] for i in opened.completed}


#: Files whose content a run may change: locks (holder records), run records, LATEST.
def _mutable(path: Path) -> bool:
    return path.suffix == ".lock" or path.parent.name == "runs" or path.name == "LATEST"


def take_snapshot(roots: Iterable[Path]) -> Snapshot:
    """Everything under ``roots`` now (sessions and bundles as units)."""
    files, sessions, bundles = {}, {}, set()
    for root in roots:
        if not root.exists():
            continue
        found_sessions = _session_dirs(root)
        found_bundles = _bundle_dirs(root)
        for session in found_sessions:
            sessions[session] = _frames(session)
        bundles.update(found_bundles)
        for path in root.rglob("*"):
            if not path.is_file() or _hidden(path, root) or _mutable(path):
                continue
            if not _inside(path, found_sessions):
                files[path] = _sha256(path)
    return Snapshot(files, sessions, bundles)


# -- checks --------------------------------------------------------------------------------


def _readable(path: Path) -> str | None:
    """Why a file is not whole, or None."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".nc":
            import xarray as xr

            with xr.open_dataset(path) as ds:
                ds.load()
        elif suffix == ".hdr":
            import spectral

            spectral.open_image(str(path)).load()
        elif suffix == ".png":
            import cv2

            if cv2.imread(str(path), cv2.IMREAD_UNCHANGED) is None:
                return "not a readable PNG"
        elif suffix in (".tif", ".tiff"):
            import tifffile

            tifffile.imread(path)
        elif suffix == ".json":
            json.loads(path.read_text("utf-8"))
        elif suffix == ".html":
            if not path.read_text("utf-8").rstrip().endswith("</html>"):
                return "HTML without its end"
        elif suffix == ".zip":
            with zipfile.ZipFile(path) as archive:
                if archive.testzip() is not None:
                    return "a damaged zip member"
        elif suffix == ".mat":
            import scipy.io

            try:
                scipy.io.loadmat(path)
            except NotImplementedError:  # MAT v7.3 is HDF5
                import h5py

                with h5py.File(path, "r") as mat:
                    list(mat.keys())
        elif suffix == ".csv":
            with open(path, newline="", encoding="utf-8") as stream:
                list(csv.reader(stream))
        elif suffix == ".npy":
            import numpy as np

            np.load(path, allow_pickle=False)
        elif suffix in (".yaml", ".yml"):
            import yaml

            yaml.safe_load(path.read_text("utf-8"))
    except Exception as exc:  # whatever the reader raises, the file is not whole
        return f"{type(exc).__name__}: {exc}"
    return None


def check_whole(roots: Iterable[Path]) -> list[str]:
    """Files under final names that are not whole, sessions or bundles that do not
    verify, a LATEST that names no version."""
    from sassi_bench.acquire.session import Session
    from sassi_bench.bundle import verify

    problems = []
    for root in roots:
        if not root.exists():
            continue
        sessions, bundles = _session_dirs(root), _bundle_dirs(root)
        for session in sessions:
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    Session.open(session).verify()
            except Exception as exc:
                problems.append(f"session {session}: {type(exc).__name__}: {exc}")
        for bundle in bundles:
            try:
                verify(bundle)
            except Exception as exc:
                problems.append(f"bundle {bundle}: {type(exc).__name__}: {exc}")
        for latest in root.rglob("LATEST"):
            named = latest.read_text("utf-8").strip()
            if not (latest.parent / named / "manifest.json").is_file():
                problems.append(f"{latest} names {named!r}, which is not a published bundle")
        for path in root.rglob("*"):
            if not path.is_file() or _hidden(path, root) or _inside(path, [*sessions, *bundles]):
                continue
            why = _readable(path)
            if why is not None:
                problems.append(f"{path}: {why}")
    return problems


def check_intact(before: Snapshot, after: Snapshot, removable: Iterable[Path] = ()) -> list[str]:
    """Earlier results that changed or went (``removable``: what the command may remove)."""
    removable = list(removable)
    problems = []
    for path, digest in before.files.items():
        if _inside(path, removable):
            continue
        if path not in after.files:
            problems.append(f"earlier result gone: {path}")
        elif after.files[path] != digest:
            problems.append(f"earlier result changed: {path}")
    for session, frames in before.sessions.items():
        if _inside(session, removable):
            continue
        now = after.sessions.get(session)
        if now is None:
            problems.append(f"earlier session gone: {session}")
        elif any(now.get(i) != sha for i, sha in frames.items()):
            problems.append(f"earlier session lost or changed frames: {session}")
    for bundle in before.bundles:
        if bundle not in after.bundles and not _inside(bundle, removable):
            problems.append(f"earlier bundle gone: {bundle}")
    return problems


def incomplete_sessions(after: Snapshot) -> list[Path]:
    """Sessions with fewer frames stored than planned."""
    out = []
    for session, frames in after.sessions.items():
        header = json.loads((session / "session.json").read_text("utf-8"))
        if len(frames) < len(header["plan"]["steps"]):
            out.append(session)
    return out


def resume_command(outcome: Outcome, data: Path) -> list[str] | None:
    """The resume command the run printed, else the one it recorded."""
    lines = outcome.stderr.strip().splitlines()
    # the program is named as it was started: sassi-bench, or its path when not on PATH
    if "Resume with:" in outcome.stderr and lines:
        words = shlex.split(lines[-1].strip())
        if words and Path(words[0]).name == PROG:
            return words
    records = sorted((data / "runs").glob("*.json")) if (data / "runs").is_dir() else []
    for record in records:
        saved = json.loads(record.read_text("utf-8"))
        if saved["status"] != "running" or outcome.signal == "SIGKILL":
            return shlex.split(saved["command"])
    return None


# -- running and stopping ------------------------------------------------------------------


#: How long a file waits under its temporary name before it is moved into place, when a
#: kill point waits for such a name (``slow_commit/sitecustomize.py``): a small file is
#: written in a few ms, under the trigger's polling interval on a quiet machine.
COMMIT_PAUSE_S = 0.3


def _env(data: Path, *, commit_pause_s: float = 0.0) -> dict[str, str]:
    env = {**os.environ, "SASSI_BENCH_DATA": str(data), "MPLBACKEND": "Agg"}
    if commit_pause_s > 0:
        slow = str(Path(__file__).parent / "slow_commit")
        env["PYTHONPATH"] = os.pathsep.join(p for p in (slow, env.get("PYTHONPATH")) if p)
        env["SASSI_FAULT_KIT_COMMIT_PAUSE_S"] = str(commit_pause_s)
    return env


def _found(roots: Iterable[Path], pattern: str, recursive: bool = False) -> list[Path]:
    """Paths matching ``pattern`` under ``roots``, walked again when a folder vanished
    mid-walk (a command renaming its temporary folder into place)."""
    while True:
        try:
            return [
                path
                for root in roots
                if root.exists()
                for path in (root.rglob(pattern) if recursive else root.glob(pattern))
            ]
        except FileNotFoundError:
            continue


def _frames_stored(roots: Iterable[Path]) -> int:
    total = 0
    for events in _found(roots, "events.jsonl", recursive=True):
        try:
            total += events.read_bytes().count(b"\n")
        except OSError:
            continue
    return total


def wait_for(trigger: str, process: subprocess.Popen, roots: Sequence[Path], start: float,
             baseline: int, timeout: float) -> bool:  # fmt: skip
    """Wait until ``trigger`` (``frames:N``, ``file:GLOB`` under the first root,
    ``seconds:S``); False if the process ended first."""
    kind, _, value = trigger.partition(":")
    while process.poll() is None:
        now = time.monotonic()
        if now - start > timeout:
            return True
        if kind == "seconds" and now - start >= float(value):
            return True
        if kind == "frames" and _frames_stored(roots) - baseline >= int(value):
            return True
        if kind == "file" and _found(roots, value):
            return True
        time.sleep(0.02)
    return False


def run_command(argv: Sequence[str], data: Path, timeout: float) -> subprocess.CompletedProcess:
    """Run a command to its end."""
    return subprocess.run(
        [str(SCRIPT), *argv], capture_output=True, text=True, timeout=timeout, env=_env(data),
        check=False,
    )  # fmt: skip


def kill_point(
    case: Case, argv: Sequence[str], data: Path, roots: Sequence[Path], signame: str, trigger: str
) -> Outcome:
    """Run ``argv`` and send ``signame`` at ``trigger``."""
    baseline = _frames_stored(roots)
    start = time.monotonic()
    process = subprocess.Popen(
        [str(SCRIPT), *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=_env(data, commit_pause_s=COMMIT_PAUSE_S if trigger.startswith("file:") else 0.0),
        # A background job inherits an ignored Ctrl-C; a user's terminal does not.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    killed = wait_for(trigger, process, roots, start, baseline, case.timeout_s)
    if killed:
        process.send_signal(SIGNALS[signame])
    try:
        out, err = process.communicate(timeout=case.timeout_s)
    finally:
        process.kill()
    return Outcome(
        case.name, signame, trigger, process.returncode, out, err, killed,
        time.monotonic() - start,
    )  # fmt: skip


def check_kill_point(
    case: Case,
    outcome: Outcome,
    before: Snapshot,
    roots: Sequence[Path],
    data: Path,
    removable: Iterable[Path] = (),
) -> Snapshot:
    """Fill ``outcome.problems`` (the three properties of the module docstring, but the
    resume itself); returns what is on disk now."""
    after = take_snapshot(roots)
    outcome.problems += check_intact(before, after, removable)
    outcome.problems += check_whole(roots)
    if "Traceback" in outcome.stderr:
        outcome.problems.append("a traceback: " + outcome.stderr.strip().splitlines()[-1])
    if not outcome.killed:
        if outcome.status not in case.ok_status:
            outcome.problems.append(f"ended with {outcome.status} before the signal")
        return after
    expected = {"SIGINT": 130, "SIGTERM": 143, "SIGKILL": -signal.SIGKILL}[outcome.signal]
    if outcome.status != expected and outcome.status not in case.ok_status:
        outcome.problems.append(f"exit status {outcome.status}, not {expected}")
    left = [s for s in incomplete_sessions(after) if s not in before.sessions or
            len(after.sessions[s]) > len(before.sessions[s])]  # fmt: skip
    if case.captures and left and resume_command(outcome, data) is None:
        outcome.problems.append(f"no resume command printed or recorded for {left}")
    return after


def resume(case: Case, outcome: Outcome, argv: Sequence[str], data: Path) -> list[str]:
    """Finish the interrupted run: the resume command for a command that captures, the
    same command again otherwise. Problems found."""
    again = resume_command(outcome, data) if case.captures else None
    command = list(again[1:]) if again else list(argv)
    outcome.resumed = shlex.join([PROG, *command])
    done = run_command(command, data, case.timeout_s)
    if done.returncode not in case.ok_status:
        tail = (done.stderr.strip().splitlines() or [""])[-1]
        return [f"resume `{outcome.resumed}` ended with {done.returncode}: {tail}"]
    return []


# -- the commands that write, and a lab to run them in -------------------------------------

#: Every command that writes. ``{out}`` is a fresh folder per kill point.
CASES = {
    c.name: c
    for c in (
        Case("calibrate", ("calibrate", "--rig", "sim", "--out", "{out}/report", "--quiet"),
             captures=True, outputs=("report/macbeth_report.html",), ok_status=(0, 1)),
        Case("calibrate spectral", ("calibrate", "spectral", "--rig", "sim", "--quiet"),
             captures=True, ok_status=(0, 1)),
        Case("calibrate response", ("calibrate", "response", "--rig", "sim", "--bundle",
                                    "v0001", "--quiet"), captures=True),
        Case("calibrate guide", ("calibrate", "guide", "--rig", "sim", "--bundle", "v0001",
                                 "--quiet"), captures=True, ok_status=(0, 1)),
        Case("scan", ("scan", "--rig", "sim", "--out", "{out}/cube.nc", "--envi",
                      "{out}/cube", "--quiet"), captures=True,
             outputs=("cube.nc", "cube.hdr")),
        Case("rig snapshot", ("rig", "snapshot", "--rig", "sim", "--out", "{out}/snap"),
             outputs=("snap/guide.png", "snap/spectral_pinholes.tiff")),
        Case("bundle export zip", ("bundle", "export", "v0001", "--zip", "{out}/b.zip"),
             outputs=("b.zip",)),
        Case("bundle export sassi-mat", ("bundle", "export", "v0001", "--format", "sassi-mat",
                                         "--out", "{out}/mat", "--quiet"),
             outputs=("mat/calibstack.mat",)),
        Case("bundle import", ("bundle", "import", "{zip}", "--data", "{other}")),
        Case("snapshot take", ("snapshot", "take", "--rig", "sim", "--frames", "2", "--out",
                               "{out}/snaps", "--quiet"), captures=True),
        Case("snapshot reconstruct", ("snapshot", "reconstruct", "--session", "world-snap",
                                      "--out", "{out}/rec", "--quiet")),
        Case("snapshot export", ("snapshot", "export", "--session", "world-snap-f000",
                                 "--step", "1", "--vsize", "9", "--out", "{out}/exp"),
             outputs=("exp/adaptive_cassi.mat",)),
        Case("validate macbeth", ("validate", "macbeth", "--rig", "sim", "--white", "patch",
                                  "--out", "{out}/macbeth", "--quiet"), captures=True,
             ok_status=(0, 1)),
        Case("validate snapshot", ("validate", "snapshot", "--rig", "sim", "--out",
                                   "{out}/vsnap", "--quiet"), captures=True, ok_status=(0, 1)),
        Case("batch assemble", ("batch", "assemble", "--sessions", "world-scan", "--out",
                                "{out}/cubes", "--workers", "1", "--quiet")),
        Case("batch validate", ("batch", "validate", "--sessions", "world-scan", "--out",
                                "{out}/scores", "--workers", "1", "--quiet"),
             ok_status=(0, 1)),
        Case("data clean", ("data", "clean", "--yes")),
    )
}  # fmt: skip

#: Commands whose output folder refuses what an interrupted run left (exports and
#: images are never replaced): they finish by running again into a fresh folder.
FRESH_OUT = {"rig snapshot", "bundle export sassi-mat", "snapshot export"}


def build_world(root: Path, bundle_dir: Path) -> dict[str, Path]:
    """A lab's data root with earlier results to protect: a published bundle with a guide
    homography (copied from ``bundle_dir``), a thin ColorChecker scan, a one-frame
    snapshot, an exported zip, a staged bundle and an orphan calibration session (what
    ``data clean`` may remove). Returns the places a command template names."""
    import shutil

    from sassi_bench import open_rig
    from sassi_bench.acquire.plan import Plan
    from sassi_bench.acquire.runner import run_plan
    from sassi_bench.acquire.scan_plans import scan_plan
    from sassi_bench.acquire.session import Session
    from sassi_bench.bundle import export_zip, load
    from sassi_bench.procedure import load_procedure
    from sassi_bench.workflows.snapshot import take_snapshots

    data = root / "data"
    (data / "sim").mkdir(parents=True)
    shutil.copytree(bundle_dir, data / "sim" / "v0001")
    (data / "sim" / "LATEST").write_text("v0001\n")
    bundle = load(data / "sim" / "v0001")
    rig = open_rig("sim")
    full = scan_plan(rig.slm.shape, "led", 0.02, scene="colorchecker")
    keep = [s for i, s in enumerate(full.steps) if s.tags["role"] == "closed" or i % 25 == 1]
    plan = Plan(full.name, tuple(keep), full.parameters)
    scan = Session.create(rig.description, plan, session_id="world-scan", data=data)
    run_plan(rig, plan, scan, progress=False)
    grey = Plan("spectral-grey", keep[:2], {"scene": "white"})
    old = Session.create(rig.description, grey, session_id="old-grey", data=data)
    run_plan(rig, grey, old, progress=False)
    take_snapshots(
        rig, bundle, load_procedure("snapshot_validation"), scene="natural", frames=1,
        session_id="world-snap", data=data, progress=False,
    )  # fmt: skip
    shutil.copytree(bundle_dir, data / "staging" / "old-run" / "sim" / "v0001")
    earlier = root / "earlier"
    earlier.mkdir()
    zipped = export_zip(bundle.path, earlier / "world.zip")
    return {"data": data, "zip": zipped, "earlier": earlier}


def removable_by(case: Case, data: Path) -> list[Path]:
    """What ``case`` may remove from the data root: for ``data clean``, what its dry run
    lists; nothing for any other command."""
    if case.name != "data clean":
        return []
    from sassi_bench.storage.clean import clean_candidates
    from sassi_bench.storage.inventory import inventory
    from sassi_bench.storage.runs import read_runs

    return [e.path for e in clean_candidates(inventory(data), runs=read_runs(data))]
