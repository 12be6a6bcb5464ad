"""Notebook outputs go under the data root, each run in its own folder, and say so."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from sassi_bench.notebook import new_report_folder, save_cube


def test_each_report_run_gets_a_new_folder_and_keeps_the_earlier(tmp_path: Path, capsys):
    first = new_report_folder("macbeth", tmp_path)
    (first / "macbeth_report.html").write_text("first")
    second = new_report_folder("macbeth", tmp_path)
    third = new_report_folder("macbeth", tmp_path)
    assert [p.name for p in (first, second, third)] == ["run-001", "run-002", "run-003"]
    assert first.parent == tmp_path / "reports" / "macbeth" and third.is_dir()
    assert (first / "macbeth_report.html").read_text() == "first"
    said = capsys.readouterr().out.splitlines()
    assert said[0].endswith("run-001 (new)")
    assert said[1].endswith("run-002 (the earlier report run-001 is kept)")
    assert said[2].endswith("(the 2 earlier reports, run-001 to run-002, are kept)")


def test_a_report_folder_chosen_by_the_user_is_under_the_data_root(tmp_path: Path):
    assert new_report_folder("macbeth", tmp_path, "mine").parent == tmp_path / "mine"
    elsewhere = tmp_path / "elsewhere"
    assert new_report_folder("macbeth", tmp_path, elsewhere).parent == elsewhere


def test_the_data_root_comes_from_the_environment(tmp_path: Path, monkeypatch):
    monkeypatch.setenv("SASSI_BENCH_DATA", str(tmp_path))
    monkeypatch.chdir(Path(__file__).resolve().parents[2] / "notebooks")
    assert new_report_folder("snapshot").parent == tmp_path / "reports" / "snapshot"


def _cube(value: float) -> xr.Dataset:
    from sassi_bench.spectra.cube_io import spectral_cube_dataset

    return spectral_cube_dataset(
        np.full((2, 4, 3), value, np.float32),
        np.array([450.0, 550.0, 650.0]),
        np.array([400.0, 500.0, 600.0, 700.0]),
        units="camera ADU per bin",
    )


def test_a_cube_is_written_once_and_kept_after(tmp_path: Path, capsys):
    path = save_cube(_cube(1.0), "scan-sim-v0001", tmp_path)
    assert path == tmp_path / "cubes" / "scan-sim-v0001.nc"
    again = save_cube(_cube(2.0), "scan-sim-v0001", tmp_path)
    assert again == path
    with xr.open_dataset(path) as cube:
        assert float(cube["radiance"].max()) == 1.0  # the first is kept, never replaced
    said = capsys.readouterr().out
    assert f"cube: wrote {path}" in said and f"cube: kept {path}" in said
