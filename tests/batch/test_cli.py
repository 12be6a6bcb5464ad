"""``sassi-bench batch``: a real run on a local cluster, and a failed session's exit status."""

from __future__ import annotations

import csv

from sassi_bench.cli import main


def test_batch_assemble_runs_every_session_and_says_where_the_summary_is(scans, tmp_path, capsys):
    data, bundle, ids = scans
    out = tmp_path / "cubes"
    argv = ["batch", "assemble", "--sessions", "scan-*", "--data", str(data), "--out", str(out)]
    status = main([*argv, "--bundle", str(bundle.path), "--workers", "2", "--quiet"])
    printed = capsys.readouterr().out
    assert status == 0, printed
    assert sorted(p.name for p in out.glob("*.nc")) == sorted(f"{s}.nc" for s in ids)
    assert "3 sessions" in printed and "on 2 workers: 3 done, 0 skipped, 0 failed" in printed
    assert str(out / "batch-assemble.csv") in printed


def test_batch_validate_scores_the_chart_and_fails_the_scans_that_are_not_charts(
    scans, tmp_path, capsys
):
    data, bundle, _ = scans
    out = tmp_path / "macbeth"
    argv = ["batch", "validate", "--all", "--data", str(data), "--out", str(out)]
    status = main([*argv, "--bundle", str(bundle.path), "--workers", "2"])
    printed = capsys.readouterr().out
    with open(out / "batch-validate.csv") as stream:
        rows = {r["session"]: r for r in csv.DictReader(stream)}
    print(rows)
    assert "dashboard: http" in printed
    assert status in (0, 1)
