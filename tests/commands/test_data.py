"""``sassi-bench data list|clean`` on a data root shaped like a lab's: what a lab measured
(bundle inputs, scans, snapshots, interrupted runs) is never cleaned unless asked."""

import json
import os
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.session import Session
from sassi_bench.commands import main
from sassi_bench.rig import Frame, FrameMeta, load_rig_description
from sassi_bench.storage.runs import record_run


def _folder(path: Path, size: int) -> Path:
    path.mkdir(parents=True)
    (path / "frames.bin").write_bytes(b"\0" * size)
    return path


def _session(path: Path, size: int, plan: str, steps: int, stored: int) -> Path:
    """A session as the workbench writes it (a plan of ``steps`` tiny frames, ``stored`` of
    them stored), with ``size`` bytes of other files beside."""
    steps_ = [Step("spectral", "off", 0.01, {"kind": "blank"})] * steps
    session = Session.create(
        load_rig_description("sim"), Plan(plan, steps_), session_id=path.name, data=path.parents[1]
    )
    for i in range(stored):
        pixels = np.full((2, 2), i, np.uint16)
        session.write_frame(i, Frame(pixels, FrameMeta("spectral", 0.01, 0.0, i, "off", i)))
    (path / "frames.bin").write_bytes(b"\0" * size)
    return path


@pytest.fixture(scope="module")
def template(tmp_path_factory) -> Path:
    """A published bundle using one session, an orphan calibration session, a chain's
    staging folder (a session the bundle uses, one it does not, intermediate bundles), a
    report, a ground-truth scan, a snapshot, and an interrupted scan with its run record."""
    root = tmp_path_factory.mktemp("lab") / "data"
    bundle = _folder(root / "sim" / "v0001", 100)
    manifest = {"inputs": [{"id": "used"}, {"id": "run-sweep"}]}
    (bundle / "manifest.json").write_text(json.dumps(manifest))
    (root / "sim" / "LATEST").write_text("v0001\n")
    _session(root / "sessions" / "used", 5000, "spectral-sweep", 3, 3)
    _session(root / "sessions" / "orphan", 3000, "spectral-sweep", 3, 3)
    _folder(root / "staging" / "run" / "sessions" / "run-sweep", 7000)
    _folder(root / "staging" / "run" / "sessions" / "run-unused", 2000)
    _folder(root / "staging" / "run" / "sim" / "v0001", 400)
    _folder(root / "reports" / "run", 50)
    _session(root / "sessions" / "scan-white-1", 9000, "pinhole-scan", 501, 501)
    _session(root / "sessions" / "snap-f000", 1000, "snapshot-f000", 2, 2)
    _session(root / "sessions" / "scan-cc-2", 4000, "pinhole-scan", 501, 120)
    record = record_run(root, "scan-cc-2", "sassi-bench scan --session scan-cc-2", ["scan-cc-2"])
    raw = json.loads(record.read_text())
    record.write_text(json.dumps({**raw, "pid": 2**22 + 17}))  # its process is gone
    return root


@pytest.fixture
def root(template: Path, tmp_path: Path) -> Path:
    """A fresh copy of the lab's data root."""
    return Path(shutil.copytree(template, tmp_path / "data"))


def _run(capsys, *argv) -> str:
    assert main(list(argv)) == 0
    return capsys.readouterr().out


def test_list_shows_every_folder_its_size_users_and_interrupted_runs(root, capsys):
    out = _run(capsys, "data", "list", "--data", str(root))
    lines = {line.split()[1]: line for line in out.splitlines()[2:] if line.split()[:1] != ["run"]}
    assert {
        "sessions/used", "sessions/orphan", "staging/run/sessions/run-sweep",
        "staging/run/sessions/run-unused", "staging/run/sim", "sim/v0001", "reports/run",
        "sessions/scan-white-1", "sessions/snap-f000", "sessions/scan-cc-2",
    } <= set(lines)  # fmt: skip
    assert lines["sessions/used"].rstrip().endswith("sim/v0001")
    assert lines["staging/run/sessions/run-sweep"].rstrip().endswith("sim/v0001")
    assert lines["sessions/orphan"].rstrip().endswith("-")
    assert "6.8 kB" in lines["staging/run/sessions/run-sweep"]
    assert "INCOMPLETE 120/501 (resumes)" in lines["sessions/scan-cc-2"]
    assert "501 frames" in lines["sessions/scan-white-1"]
    assert "run scan-cc-2: interrupted (its process is gone)" in out
    assert "  sassi-bench scan --session scan-cc-2" in out


def test_clean_keeps_measurements_inputs_and_interrupted_runs_unless_asked(root, capsys):
    before = sorted(p for p in root.rglob("*"))
    out = _run(capsys, "data", "clean", "--data", str(root))
    assert "dry run: 3 folder(s)" in out and "add --yes" in out
    kept = r"keeping {} folder\(s\) \([0-9.]+ kB\): {}"
    assert re.search(kept.format(2, "sessions that published bundles use"), out)
    assert re.search(kept.format(2, "scans and snapshots taken by commands"), out)
    assert "(--include-measurements removes them too)" in out
    assert re.search(kept.format(1, "sessions of interrupted runs"), out)
    assert sorted(p for p in root.rglob("*")) == before
    _run(capsys, "data", "clean", "--data", str(root), "--yes")
    for gone in ("sessions/orphan", "staging/run/sim", "staging/run/sessions/run-unused"):
        assert not (root / gone).exists(), gone
    kept = ("sessions/used", "staging/run/sessions/run-sweep", "sim/v0001", "reports/run",
            "sessions/scan-white-1", "sessions/snap-f000", "sessions/scan-cc-2")  # fmt: skip
    for folder in kept:
        assert (root / folder).is_dir(), folder
    assert not [p for p in root.rglob(".*") if p.is_dir()], "no hidden leftovers"
    out = _run(capsys, "data", "clean", "--data", str(root), "--include-measurements", "--yes")
    assert "removed 2 folder(s)" in out and not (root / "sessions" / "scan-white-1").exists()
    assert (root / "sessions" / "scan-cc-2").is_dir()  # interrupted: still kept
    out = _run(capsys, "data", "clean", "--data", str(root), "--include-interrupted",
               "--include-measurements", "--yes")  # fmt: skip
    assert not (root / "sessions" / "scan-cc-2").exists()
    out = _run(capsys, "data", "clean", "--data", str(root), "--include-referenced", "--yes")
    assert "removed 2 folder(s)" in out
    assert (root / "sim" / "v0001" / "manifest.json").is_file()
    _run(capsys, "data", "clean", "--data", str(root), "--reports", "--yes")
    assert not (root / "reports" / "run").exists() and (root / "sim" / "v0001").is_dir()


def test_a_running_run_s_sessions_are_never_cleaned(root, capsys):
    record_run(root, "scan-cc-2", "sassi-bench scan --session scan-cc-2", ["scan-cc-2"])
    out = _run(capsys, "data", "list", "--data", str(root))
    assert "capturing 120/501" in out and "run scan-cc-2: running (pid" in out
    _run(capsys, "data", "clean", "--data", str(root), "--include-interrupted",
         "--include-measurements", "--yes")  # fmt: skip
    assert (root / "sessions" / "scan-cc-2").is_dir()


def test_leftovers_of_interrupted_writes_are_listed_and_cleaned(root, capsys):
    leftover = _folder(root / "sessions" / ".scan-x.0123456789ab.tmp", 10)
    old = time.time() - 2 * 3600
    for path in (leftover / "frames.bin", leftover):
        os.utime(path, (old, old))
    out = _run(capsys, "data", "list", "--data", str(root))
    assert "leftover of an interrupted write" in out
    _run(capsys, "data", "clean", "--data", str(root), "--yes")
    assert not leftover.exists()


def test_calibrate_says_where_its_data_went(tmp_path, capsys):
    from sassi_bench.commands.calibrate import _print_data_use

    staging = _folder(tmp_path / "staging" / "full-x" / "sessions" / "s", 2048).parents[1]
    _print_data_use(staging, tmp_path / "sim" / "v0001", str(tmp_path))
    out = capsys.readouterr().out
    assert f"raw data: {staging} (2.0 kB: this run's sessions, the inputs of sim/v0001)" in out
    assert f"sassi-bench data clean --data {tmp_path}" in out
