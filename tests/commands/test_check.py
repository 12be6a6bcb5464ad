"""``sassi-bench check history`` counts the checks it draws in words: one check, two
checks, on the terminal and on the page."""

from __future__ import annotations

import re

from sassi_bench.commands import main
from sassi_bench.storage.health_history import COLUMNS, HealthHistory, history_path


def _record(data, when: str) -> None:
    row = {c: 0.0 for c in COLUMNS} | {
        "checked_utc": when, "rig": "sim", "rig_sha256": "a" * 64, "bundle_version": "v0001",
        "bundle_sha256": "b" * 64, "light": "lamp:HgAr", "frames": 2, "pinholes": 102,
        "tolerance_px": 0.1, "tolerance_nm": 0.3, "verdict": "holds", "parts_json": "{}",
        "map_json": "{}", "software": "test", "session_id": "check-1",
    }  # fmt: skip
    HealthHistory(history_path(data)).append(row)


def test_history_says_1_check_and_2_checks(tmp_path, capsys):
    for count, when in enumerate(["2026-11-25T09:00:00+00:00", "2026-11-26T09:00:00+00:00"], 1):
        _record(tmp_path, when)
        page = tmp_path / f"trend-{count}.html"
        argv = ["check", "history", "--rig", "sim", "--data", str(tmp_path), "--out", str(page)]
        assert main(argv) == 0
        printed = capsys.readouterr().out
        words = "1 check" if count == 1 else "2 checks"
        assert printed.startswith(f"{words} of sim; latest {when}: holds\n")
        assert re.search(rf"<p>{words}\. ", page.read_text())
