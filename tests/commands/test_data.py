"""``sassi-bench data list|clean`` on a data root shaped like a lab's."""

import json
from pathlib import Path

import pytest

from sassi_bench.commands import main


def _folder(path: Path, size: int) -> Path:
    path.mkdir(parents=True)
    (path / "frames.bin").write_bytes(b"\0" * size)
    return path


@pytest.fixture
def root(tmp_path: Path) -> Path:
    """A published bundle using one session, an orphan session, a chain's staging
    folder (a session the bundle uses, one it does not, intermediate bundles) and a report."""
    root = tmp_path / "data"
    bundle = _folder(root / "sim" / "v0001", 100)
    manifest = {"inputs": [{"id": "used"}, {"id": "run-sweep"}]}
    (bundle / "manifest.json").write_text(json.dumps(manifest))
    (root / "sim" / "LATEST").write_text("v0001\n")
    _folder(root / "sessions" / "used", 5000)
    _folder(root / "sessions" / "orphan", 3000)
    _folder(root / "staging" / "run" / "sessions" / "run-sweep", 7000)
    _folder(root / "staging" / "run" / "sessions" / "run-unused", 2000)
    _folder(root / "staging" / "run" / "sim" / "v0001", 400)
    _folder(root / "reports" / "run", 50)
    return root


def _run(capsys, *argv) -> str:
    assert main(list(argv)) == 0
    return capsys.readouterr().out


def test_list_shows_every_folder_its_size_and_users(root, capsys):
    out = _run(capsys, "data", "list", "--data", str(root))
    lines = {line.split()[1]: line for line in out.splitlines()[2:-1]}
    assert set(lines) == {
        "sessions/used", "sessions/orphan", "staging/run/sessions/run-sweep",
        "staging/run/sessions/run-unused", "staging/run/sim", "sim/v0001", "reports/run",
    }  # fmt: skip
    assert lines["sessions/used"].rstrip().endswith("sim/v0001")
    assert lines["staging/run/sessions/run-sweep"].rstrip().endswith("sim/v0001")
    assert lines["sessions/orphan"].rstrip().endswith("-")
    assert "6.8 kB" in lines["staging/run/sessions/run-sweep"]
    assert "total 17.2 kB" in out  # the frames and the manifest


def test_clean_is_a_dry_run_and_spares_bundles_and_their_inputs(root, capsys):
    before = sorted(p for p in root.rglob("*"))
    out = _run(capsys, "data", "clean", "--data", str(root))
    assert "dry run: 3 folder(s)" in out and "add --yes" in out
    assert "keeping 2 session(s)" in out
    assert sorted(p for p in root.rglob("*")) == before
    _run(capsys, "data", "clean", "--data", str(root), "--yes")
    assert not (root / "sessions" / "orphan").exists()
    assert not (root / "staging" / "run" / "sim").exists()
    assert not (root / "staging" / "run" / "sessions" / "run-unused").exists()
    for kept in ("sessions/used", "staging/run/sessions/run-sweep", "sim/v0001", "reports/run"):
        assert (root / kept).is_dir(), kept
    out = _run(capsys, "data", "clean", "--data", str(root), "--include-referenced", "--yes")
    assert "removed 2 folder(s)" in out
    assert not (root / "staging").exists() or not any((root / "staging").iterdir())
    assert (root / "sim" / "v0001" / "manifest.json").is_file()
    _run(capsys, "data", "clean", "--data", str(root), "--reports", "--yes")
    assert not (root / "reports" / "run").exists() and (root / "sim" / "v0001").is_dir()


def test_calibrate_says_where_its_data_went(tmp_path, capsys):
    from sassi_bench.commands.calibrate import _print_data_use

    staging = _folder(tmp_path / "staging" / "full-x" / "sessions" / "s", 2048).parents[1]
    _print_data_use(staging, tmp_path / "sim" / "v0001", str(tmp_path))
    out = capsys.readouterr().out
    assert f"raw data: {staging} (2.0 kB: this run's sessions, the inputs of sim/v0001)" in out
    assert f"sassi-bench data clean --data {tmp_path}" in out
