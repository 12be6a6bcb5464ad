"""Results are never replaced, and an output that is taken is refused before anything is
captured: no session, no frame, no run record."""

from __future__ import annotations

from pathlib import Path

import pytest

from sassi_bench.commands import main


def _refused(capsys, argv, taken: Path) -> str:
    status = main(argv)
    err = capsys.readouterr().err
    assert status == 2, err
    assert err.startswith("error: ") and f"{taken} already exists" in err, err
    assert err.count("\n") == 1
    return err


CASES = {
    "scan --out": (["scan", "--out", "{root}/cube.nc"], "cube.nc"),
    "scan --envi": (["scan", "--out", "{root}/new.nc", "--envi", "{root}/cube"], "cube.img"),
    "validate macbeth": (["validate", "macbeth", "--out", "{root}"], "macbeth_report.html"),
    "validate snapshot": (["validate", "snapshot", "--out", "{root}"], "scan.nc"),
    "calibrate": (["calibrate", "--out", "{root}"], "macbeth_report.json"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_a_taken_output_is_refused_before_any_capture(case, tmp_path, capsys):
    template, name = CASES[case]
    earlier = tmp_path / name
    earlier.write_bytes(b"an earlier result")
    data = tmp_path / "data"
    argv = [part.format(root=tmp_path) for part in template] + ["--data", str(data)]
    _refused(capsys, argv, earlier)
    assert earlier.read_bytes() == b"an earlier result"
    assert not (data / "sessions").exists() and not (data / "staging").exists()
    assert not list(data.glob("runs/*.json")), "a refused run leaves no record"
