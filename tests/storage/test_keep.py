"""A published chain's keep policy: which sessions keep their frames, what stays of the rest."""

from __future__ import annotations

import json

import pytest

from sassi_bench.storage.keep import DROPPED_NOTE, keep_frames

SESSIONS = ("run-spectral-grey", "run-spectral-sweep", "run-response", "run-macbeth-chart")


@pytest.fixture
def staging(tmp_path):
    for name in SESSIONS:
        folder = tmp_path / "sessions" / name
        (folder / "frames.zarr" / "spectral").mkdir(parents=True)
        (folder / "frames.zarr" / "spectral" / "c0").write_bytes(b"x" * 1000)
        (folder / "session.json").write_text(json.dumps({"id": name}))
        (folder / "events.jsonl").write_text('{"step": 0, "sha256": "ab"}\n')
    return tmp_path


def test_audit_keeps_the_spectral_frames_and_the_record_of_every_session(staging):
    kept = keep_frames(staging, "run", "audit")
    assert set(kept.kept) == {"run-spectral-grey", "run-spectral-sweep"}
    assert kept.dropped == {"run-response": 1000, "run-macbeth-chart": 1000}
    for name in SESSIONS:
        folder = staging / "sessions" / name
        assert (folder / "frames.zarr").is_dir() == (name in kept.kept)
        assert (folder / "session.json").read_text() == json.dumps({"id": name})
        assert (folder / "events.jsonl").is_file()
    note = json.loads((staging / "sessions" / "run-response" / DROPPED_NOTE).read_text())
    assert note["bytes"] == 1000 and "keep: audit" in note["why"]
    assert kept.lines()[1] == "dropped: run-macbeth-chart 1000 B, run-response 1000 B"


def test_all_keeps_every_frame_and_records_none(staging):
    assert set(keep_frames(staging, "run", "all").kept) == set(SESSIONS)
    records = keep_frames(staging, "run", "records")
    assert not records.kept and set(records.dropped) == set(SESSIONS)
    assert records.lines()[0] == "kept (keep: records): no frames"
    assert not list(staging.glob("sessions/*/frames.zarr"))
