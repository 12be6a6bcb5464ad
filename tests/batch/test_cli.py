"""``sassi-bench batch`` on the shared two-worker cluster, reached as a lab's scheduler
(``--scheduler``): every session assembled, and a failed session's exit status."""

from __future__ import annotations

import csv

from sassi_bench.commands import main


def _batch(kind: str, scans, client, out, *extra: str) -> list[str]:
    data, bundle, _ = scans
    return [
        "batch", kind, "--data", str(data), "--out", str(out), "--bundle", str(bundle.path),
        "--scheduler", client.scheduler.address, *extra,
    ]  # fmt: skip


def test_batch_assemble_runs_every_session_and_says_where_the_summary_is(
    scans, client, tmp_path, capsys
):
    out = tmp_path / "cubes"
    status = main(_batch("assemble", scans, client, out, "--sessions", "scan-*", "--quiet"))
    printed = capsys.readouterr().out
    assert status == 0, printed
    assert sorted(p.name for p in out.glob("*.nc")) == sorted(f"{s}.nc" for s in scans[2])
    assert "3 sessions" in printed and "on 2 workers: 3 done, 0 skipped, 0 failed" in printed
    assert str(out / "batch-assemble.csv") in printed
    assert f"next:\n  open {(out / 'batch-assemble.html').as_uri()}\n" in printed


def test_a_failed_session_is_listed_with_its_error_and_exit_status_1(
    scans, client, tmp_path, capsys
):
    """The synthetic bundle's wavelength map is not the sim rig's: the chart is not found.
    The advice never suggests deleting a measurement."""
    out = tmp_path / "macbeth"
    status = main(_batch("validate", scans, client, out, "--sessions", "scan-colorchecker"))
    printed = capsys.readouterr().out
    assert status == 1
    assert "dashboard: http" in printed
    assert "FAILED scan-colorchecker: LocateError: Macbeth patch detection" in printed
    assert "remove" not in printed.lower() and "delete" not in printed.lower()
    assert "no session was changed" in printed and "next:" not in printed
    with open(out / "batch-validate.csv") as stream:
        (row,) = csv.DictReader(stream)
    assert row["status"] == "failed" and row["frames"] == "20"
    assert row["error"].startswith("LocateError: Macbeth patch detection")


def test_validate_scores_colorchecker_scans_only(scans, client, tmp_path, capsys):
    """A white reference or a natural scene is no chart: ``--all`` leaves them out (and
    says so), a pattern that names them is refused before a cluster starts."""
    status = main(_batch("validate", scans, client, tmp_path / "all", "--all"))
    printed = capsys.readouterr().out
    left_out = "1 ColorChecker scan(s); not charts, left out: scan-pcb (pcb), scan-white (white)"
    assert left_out in printed
    assert "1 sessions in" in printed and "FAILED scan-white" not in printed
    assert status == 1  # the synthetic bundle does not find the chart (see above)
    status = main(_batch("validate", scans, client, tmp_path / "some", "--sessions", "scan-*"))
    err = capsys.readouterr().err
    refused = "scan-pcb (pcb), scan-white (white) are not a pinhole scan of the colorchecker"
    assert status == 2 and refused in err
    assert not (tmp_path / "some").exists()
