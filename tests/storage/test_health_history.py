"""The health-check history: one SQLite row per check, safe with several writers."""

import multiprocessing

import pytest

from sassi_bench.errors import ProcedureError
from sassi_bench.storage.health_history import COLUMNS, HealthHistory, history_path


def _row(**changes):
    row = {c: 0.0 for c in COLUMNS}
    row.update(
        checked_utc="2026-11-25T09:00:00+00:00",
        rig="sim",
        rig_sha256="a" * 64,
        bundle_version="v0001",
        bundle_sha256="b" * 64,
        light="lamp:HgAr",
        frames=2,
        pinholes=102,
        verdict="holds",
        parts_json={"dispersion (columns)": "holds"},
        map_json={"u": [0.0], "v": [0.0], "dx_px": [0.01]},
        software="test",
        session_id="check-1",
    )
    row.update(changes)
    return row


def test_rows_come_back_in_time_order_filtered_by_rig_and_time(tmp_path):
    history = HealthHistory(history_path(tmp_path))
    assert history.rows() == []
    history.append(_row(checked_utc="2026-11-25T15:00:00+00:00", verdict="recalibrate"))
    history.append(_row())
    history.append(_row(rig="sim-prototype"))
    rows = history.rows(rig="sim")
    assert [r["verdict"] for r in rows] == ["holds", "recalibrate"]
    assert rows[0]["parts_json"] == '{"dispersion (columns)": "holds"}'
    assert [r["verdict"] for r in history.rows(rig="sim", since="2026-11-25T12")] == ["recalibrate"]
    assert history.path == tmp_path / "health" / "checks.sqlite"


def test_a_record_without_every_column_or_with_a_bad_verdict_is_refused(tmp_path):
    history = HealthHistory(tmp_path / "checks.sqlite")
    row = _row()
    del row["bundle_sha256"]
    with pytest.raises(ProcedureError, match="health history: the record has no bundle_sha256"):
        history.append(row)
    with pytest.raises(Exception, match="CHECK constraint"):
        history.append(_row(verdict="maybe"))
    assert history.rows() == []


def _writer(path, k):
    history = HealthHistory(path)
    for i in range(25):
        history.append(_row(session_id=f"w{k}-{i}"))


def test_four_processes_appending_at_once_lose_no_row(tmp_path):
    path = tmp_path / "checks.sqlite"
    context = multiprocessing.get_context("spawn")
    workers = [context.Process(target=_writer, args=(path, k)) for k in range(4)]
    for w in workers:
        w.start()
    for w in workers:
        w.join(60)
    assert [w.exitcode for w in workers] == [0, 0, 0, 0]
    rows = HealthHistory(path).rows()
    assert len(rows) == 100
    assert len({r["session_id"] for r in rows}) == 100
