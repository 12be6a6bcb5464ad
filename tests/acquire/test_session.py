"""Raw sessions on disk: layout, one chunk per frame, crash safety, integrity, resuming."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tracemalloc
from datetime import datetime
from pathlib import Path

import numpy as np
import pytest
import zarr

from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.session import (
    SCHEMA_NAME,
    Session,
    SessionError,
    SessionIntegrityError,
    SessionLockedError,
    SessionWarning,
    frame_sha256,
)
from sassi_bench.acquire.session.events import EventLog
from sassi_bench.acquire.session.frames import FrameStore
from sassi_bench.errors import SassiBenchError
from sassi_bench.rig.config import rig_description_from_dict


def new_session(rig_description, plan, data, session_id="s1") -> Session:
    return Session.create(rig_description, plan, session_id=session_id, data=data)


def fill(session: Session, make_frame, steps=None) -> None:
    for i in session.missing if steps is None else steps:
        camera = session.plan.steps[i].camera
        session.write_frame(i, make_frame(camera, value=10 * i, index=i))


def snapshot_files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in root.rglob("*") if p.is_file()}


# -- creating and opening ----------------------------------------------------------------
def test_create_writes_session_json(rig_description, mixed_plan, data):
    session = new_session(rig_description, mixed_plan, data)
    assert session.path == data / "sessions" / "s1"
    info = json.loads((session.path / "session.json").read_text())
    assert info["schema"] == SCHEMA_NAME and info["version"] == "1.0"
    assert info["id"] == "s1"
    created = datetime.fromisoformat(info["created"].replace("Z", "+00:00"))
    assert created.utcoffset().total_seconds() == 0
    assert info["rig"] == rig_description.to_dict()
    assert info["rig_sha256"] == rig_description.sha256()
    assert info["plan"] == mixed_plan.to_dict()
    assert info["plan_sha256"] == mixed_plan.sha256()
    assert "sassi_bench" in info["software"]
    assert (session.path / "events.jsonl").read_bytes() == b""
    assert json.loads((session.path / "frames.zarr" / "zarr.json").read_text())["zarr_format"] == 3
    assert session.missing == (0, 1, 2, 3, 4) and not session.is_complete
    assert session.rig == rig_description.to_dict() and session.plan == mixed_plan
    # No staging folders are left behind.
    assert [p.name for p in (data / "sessions").iterdir()] == ["s1"]


def test_default_id_is_utc_time_and_plan_name(rig_description, data, pinhole_step):
    plan = Plan("laser sweep/532", [pinhole_step(0)])
    session = Session.create(rig_description, plan, data=data)
    assert re.fullmatch(r"\d{8}T\d{6}Z-laser-sweep-532", session.id)


def test_create_refuses_an_existing_session(rig_description, mixed_plan, data):
    session = new_session(rig_description, mixed_plan, data)
    before = snapshot_files(session.path)
    with pytest.raises(SessionError, match=r"already exists.*resume it.*another session id"):
        new_session(rig_description, mixed_plan, data)
    assert snapshot_files(session.path) == before


def test_invalid_session_ids_are_refused(rig_description, mixed_plan, data):
    for bad in ("../escape", "", ".hidden", "a b"):
        with pytest.raises(SessionError, match="session id"):
            new_session(rig_description, mixed_plan, data, session_id=bad)


def test_open_by_id_or_path(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    fill(session, make_frame, [0, 1])
    for key in ("s1", session.path, str(session.path)):
        again = Session.open(key, data=data)
        assert again.completed == {0, 1}
        assert again.plan == mixed_plan
        assert again.sha256() == session.sha256()
    with pytest.raises(SessionError, match=r"no session at .*Fix: check the id"):
        Session.open("nope", data=data)


def test_open_detects_an_edited_session_json(rig_description, mixed_plan, data):
    session = new_session(rig_description, mixed_plan, data)
    file = session.path / "session.json"
    info = json.loads(file.read_text())
    info["plan"]["steps"][0]["exposure_s"] = 1.0
    file.write_text(json.dumps(info))
    with pytest.raises(SessionIntegrityError, match="sha256"):
        Session.open("s1", data=data)


def test_open_or_create_resumes_the_same_plan_and_rig(
    rig_description, mixed_plan, data, make_frame
):
    first = Session.open_or_create(rig_description, mixed_plan, session_id="run", data=data)
    fill(first, make_frame, [0])
    again = Session.open_or_create(rig_description, mixed_plan, session_id="run", data=data)
    assert again.completed == {0}


def test_open_or_create_refuses_another_plan(
    rig_description, mixed_plan, data, make_frame, pinhole_step
):
    session = Session.open_or_create(rig_description, mixed_plan, session_id="run", data=data)
    fill(session, make_frame, [0])
    before = snapshot_files(session.path)
    other = Plan("other", [pinhole_step(7)])
    with pytest.raises(SessionError, match=r"created for plan 'mixed'.*another session id"):
        Session.open_or_create(rig_description, other, session_id="run", data=data)
    assert snapshot_files(session.path) == before


def test_open_or_create_refuses_another_rig(rig_description, mixed_plan, data, sim_dict):
    Session.open_or_create(rig_description, mixed_plan, session_id="run", data=data)
    sim_dict["seed"] = 99
    other_rig = rig_description_from_dict(sim_dict)
    with pytest.raises(SessionError, match="differs from rig"):
        Session.open_or_create(other_rig, mixed_plan, session_id="run", data=data)


# -- frames on disk ----------------------------------------------------------------------
def test_one_chunk_per_frame_and_per_camera_slots(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    fill(session, make_frame)
    frames = session.path / "frames.zarr"
    spectral = json.loads((frames / "spectral" / "zarr.json").read_text())
    guide = json.loads((frames / "guide" / "zarr.json").read_text())
    assert spectral["shape"] == [3, 6, 8] and spectral["data_type"] == "uint16"
    assert spectral["chunk_grid"]["configuration"]["chunk_shape"] == [1, 6, 8]
    assert guide["shape"] == [2, 4, 5, 3]
    assert guide["chunk_grid"]["configuration"]["chunk_shape"] == [1, 4, 5, 3]
    assert spectral["attributes"]["steps"] == [0, 2, 3]
    assert guide["attributes"]["steps"] == [1, 4]
    spectral_chunks = sorted(p.relative_to(frames) for p in (frames / "spectral").rglob("c/*/*/*"))
    assert [str(p) for p in spectral_chunks] == [f"spectral/c/{k}/0/0" for k in range(3)]
    assert len([p for p in (frames / "guide").rglob("c/*/*/*/*") if p.is_file()]) == 2
    slots = {e["step"]: (e["camera"], e["slot"]) for e in session.events()}
    assert slots == {
        0: ("spectral", 0),
        1: ("guide", 0),
        2: ("spectral", 1),
        3: ("spectral", 2),
        4: ("guide", 1),
    }
    assert session.is_complete and session.missing == ()


def test_frames_read_back_exactly_and_read_only(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    fill(session, make_frame)
    reopened = Session.open("s1", data=data)
    for i, step in enumerate(mixed_plan.steps):
        expected = make_frame(step.camera, value=10 * i).data
        got = reopened.read_frame(i)
        np.testing.assert_array_equal(got, expected)
        assert got.dtype == np.uint16 and not got.flags.writeable
    assert reopened.read_frame(1).shape == (4, 5, 3)
    stacked = reopened.read_frames([3, 0])
    assert stacked.shape == (2, 6, 8)
    np.testing.assert_array_equal(stacked[0], make_frame("spectral", value=30).data)
    with pytest.raises(SessionError, match="mix cameras"):
        reopened.read_frames([0, 1])


def test_events_describe_each_frame(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    frame = make_frame("spectral", value=5, index=3)
    session.write_frame(2, frame)
    (event,) = session.events()
    assert event["step"] == 2 and event["camera"] == "spectral" and event["slot"] == 1
    assert event["meta"] == frame.meta.to_dict()
    assert event["pattern"] == mixed_plan.steps[2].to_dict()["pattern"]
    assert event["tags"] == {"role": "pinholes", "offset_x": 1}
    assert event["sha256"] == frame_sha256(frame.data)
    assert event["dtype"] == "<u2" and event["shape"] == [6, 8]
    line = (session.path / "events.jsonl").read_text()
    assert line.endswith("\n") and json.loads(line) == event
    assert session.event(2) == event


def test_event_is_appended_only_after_the_chunk_is_on_disk(
    rig_description, mixed_plan, data, make_frame, monkeypatch
):
    session = new_session(rig_description, mixed_plan, data)
    original = EventLog.append
    seen = []

    def checking_append(self, event):
        chunk = session.path / "frames.zarr" / "spectral" / "c" / "0" / "0" / "0"
        seen.append(chunk.is_file())
        # The data must already read back from disk, independently of this object.
        stored = zarr.open_array(session.path / "frames.zarr" / "spectral", mode="r")
        np.testing.assert_array_equal(stored[0], make_frame(value=0).data)
        original(self, event)

    monkeypatch.setattr(EventLog, "append", checking_append)
    session.write_frame(0, make_frame(value=0))
    assert seen == [True]


def test_a_failed_chunk_write_logs_no_event(
    rig_description, mixed_plan, data, make_frame, monkeypatch
):
    session = new_session(rig_description, mixed_plan, data)

    def crash(self, camera, slot):
        raise OSError("disk full")

    monkeypatch.setattr(FrameStore, "_sync_chunk", crash)
    with pytest.raises(OSError, match="disk full"):
        session.write_frame(0, make_frame())
    monkeypatch.undo()
    assert session.completed == frozenset()
    assert (session.path / "events.jsonl").read_bytes() == b""
    reopened = Session.open("s1", data=data)
    assert 0 in reopened.missing
    with pytest.raises(SessionError, match="never captured"):
        reopened.read_frame(0)
    reopened.write_frame(0, make_frame(value=3))  # the step is simply captured again
    np.testing.assert_array_equal(reopened.read_frame(0), make_frame(value=3).data)


def test_torn_last_line_is_ignored_reported_and_repaired(
    rig_description, mixed_plan, data, make_frame
):
    session = new_session(rig_description, mixed_plan, data)
    fill(session, make_frame, [0, 1])
    events = session.path / "events.jsonl"
    good = events.read_bytes()
    torn = b'{"camera":"spectral","dtype":"<u2","meta":{"cam'
    events.write_bytes(good + torn)

    with pytest.warns(SessionWarning, match="torn last line"):
        reopened = Session.open("s1", data=data)
    assert reopened.completed == {0, 1}
    assert any("torn" in p for p in reopened.problems)
    assert reopened.sha256() == session.sha256()

    fill(reopened, make_frame, [2])
    assert (session.path / "events.torn").read_bytes() == torn + b"\n"
    lines = events.read_bytes().splitlines()
    assert [json.loads(line)["step"] for line in lines] == [0, 1, 2]
    final = Session.open("s1", data=data)
    assert final.completed == {0, 1, 2} and final.problems == ()


def test_a_damaged_line_before_the_end_is_an_integrity_error(
    rig_description, mixed_plan, data, make_frame
):
    session = new_session(rig_description, mixed_plan, data)
    fill(session, make_frame, [0, 1])
    events = session.path / "events.jsonl"
    lines = events.read_bytes().splitlines(keepends=True)
    events.write_bytes(b"garbage\n" + lines[1])
    with pytest.raises(SessionIntegrityError, match="line 1 is damaged"):
        Session.open("s1", data=data)


def test_writers_in_turn_see_each_others_frames(rig_description, mixed_plan, data, make_frame):
    """Two Session objects of one session write in turn: the lock makes each read the
    frames the other stored, so nothing is truncated or captured twice."""
    first = new_session(rig_description, mixed_plan, data)
    second = Session.open("s1", data=data)
    fill(first, make_frame, [0])
    fill(second, make_frame, [2])
    assert second.completed == {0, 2}
    with pytest.raises(SessionError, match="already stored"):
        fill(second, make_frame, [0])
    assert Session.open("s1", data=data).completed == {0, 2}


def test_a_writer_holds_the_session_against_others(rig_description, mixed_plan, data, make_frame):
    first = new_session(rig_description, mixed_plan, data)
    second = Session.open("s1", data=data)
    with first.writing():
        assert first.locked_for_writing
        with pytest.raises(SessionLockedError, match=rf"pid {os.getpid()} on .*Fix: let it"):
            fill(second, make_frame, [1])
        assert Session.open("s1", data=data).completed == frozenset()  # reading is fine
    fill(second, make_frame, [1])
    assert not first.locked_for_writing and second.completed == {1}


_HOLD = """
import sys, time
from sassi_bench.acquire.session import Session
session = Session.open(sys.argv[1], data=sys.argv[2])
session.lock_for_writing()
print("locked", flush=True)
time.sleep(60)
"""


def test_a_second_process_gets_the_holders_pid(rig_description, mixed_plan, data, make_frame):
    new_session(rig_description, mixed_plan, data)
    holder = subprocess.Popen(
        [sys.executable, "-c", _HOLD, "s1", str(data)], stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "locked"
        session = Session.open("s1", data=data)
        with pytest.raises(SessionLockedError, match=rf"pid {holder.pid} on "):
            fill(session, make_frame, [0])
        assert session.completed == frozenset()
    finally:
        holder.kill()
        holder.wait()
    # The lock of a process that died is released by the operating system.
    fill(session, make_frame, [0])
    assert Session.open("s1", data=data).completed == {0}


def test_frame_metadata_must_be_json(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    frame = make_frame()
    frame.meta.extra["when"] = object()
    with pytest.raises(SessionError, match=r"write step 0: the frame metadata is not JSON"):
        session.write_frame(0, frame)
    assert session.completed == frozenset()


def test_completed_steps_are_never_overwritten(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    session.write_frame(0, make_frame(value=1))
    with pytest.raises(SessionError, match=r"write step 0: .*already stored.*new session"):
        session.write_frame(0, make_frame(value=2))
    with pytest.raises(SessionError, match="already stored"):
        Session.open("s1", data=data).write_frame(0, make_frame(value=2))
    np.testing.assert_array_equal(session.read_frame(0), make_frame(value=1).data)


def test_write_frame_checks_index_camera_and_shape(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    with pytest.raises(SessionError, match=r"step index 5 is out of range.*use 0\.\.4"):
        session.write_frame(5, make_frame())
    with pytest.raises(SessionError, match="not an integer"):
        session.write_frame(True, make_frame())  # type: ignore[arg-type]
    with pytest.raises(
        SessionError, match=r"step 1: .*guide camera but the frame came from spectral"
    ):
        session.write_frame(1, make_frame("spectral"))
    with pytest.raises(SessionError, match=r"guide frame has shape \(4, 5\), expected \(H, W, 3\)"):
        session.write_frame(1, make_frame("adapter-7", shape=(4, 5)))
    session.write_frame(0, make_frame())
    with pytest.raises(SessionError, match=r"step 2: .*stored so far are uint16 \(6, 8\)"):
        session.write_frame(2, make_frame(shape=(6, 9)))
    assert isinstance(SessionError("x"), SassiBenchError)
    assert session.completed == {0}


def test_read_of_a_step_never_captured_names_the_fix(rig_description, mixed_plan, data):
    session = new_session(rig_description, mixed_plan, data)
    with pytest.raises(
        SessionError, match=r"read step 3: this step was never captured.*run the plan"
    ):
        session.read_frame(3)


# -- identity and integrity -------------------------------------------------------------
def test_sha256_covers_session_json_and_completed_events(
    rig_description, mixed_plan, data, make_frame
):
    session = new_session(rig_description, mixed_plan, data)
    empty = session.sha256()
    fill(session, make_frame, [2, 0])
    two = session.sha256()
    assert two != empty
    assert Session.open("s1", data=data).sha256() == two
    fill(session, make_frame, [1])
    assert session.sha256() != two
    # Content identity, not log order: same frames logged in another order, same hash.
    other = new_session(rig_description, mixed_plan, data, session_id="s2")
    (other.path / "session.json").write_bytes((session.path / "session.json").read_bytes())
    lines = (session.path / "events.jsonl").read_bytes().splitlines(keepends=True)
    (other.path / "events.jsonl").write_bytes(b"".join(reversed(lines)))
    assert Session.open(other.path).sha256() == session.sha256()


def test_verify_detects_a_modified_chunk(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    fill(session, make_frame)
    assert session.verify() == 5
    chunk = session.path / "frames.zarr" / "spectral" / "c" / "2" / "0" / "0"  # step 3
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    raw[-3] ^= 0x5A
    chunk.write_bytes(bytes(raw))
    with pytest.raises(SessionIntegrityError, match=r"verify step 3: .*spectral frame \(slot 2, "):
        Session.open("s1", data=data).verify()


def test_verify_detects_a_deleted_chunk(rig_description, mixed_plan, data, make_frame):
    session = new_session(rig_description, mixed_plan, data)
    fill(session, make_frame)
    (session.path / "frames.zarr" / "guide" / "c" / "1" / "0" / "0" / "0").unlink()
    with pytest.raises(SessionIntegrityError, match=r"verify step 4: .* is missing: its chunk"):
        session.verify()


# -- bounded memory ----------------------------------------------------------------------
def test_iter_frames_reads_one_chunk_at_a_time(rig_description, data, make_frame, pinhole_step):
    shape = (256, 512)  # 256 KiB per frame
    n = 12
    plan = Plan("big", [pinhole_step(k) for k in range(n)])
    session = new_session(rig_description, plan, data)
    rng = np.random.default_rng(0)
    for i in range(n):
        pixels = rng.integers(0, 4096, shape, dtype=np.uint16)
        frame = make_frame(shape=shape, index=i)
        session.write_frame(i, type(frame)(pixels, frame.meta))
    frame_bytes = 2 * shape[0] * shape[1]

    def peak_after_the_first_frame() -> int:
        frames = session.iter_frames(range(n))
        first = next(frames)
        assert first.shape == shape and not first.flags.writeable
        del first
        tracemalloc.start()
        try:
            assert sum(int(f[0, 0]) for f in frames) >= 0
            return tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()

    # tracemalloc counts every thread of the process: a thread an earlier test left in the
    # same test process can allocate inside one window, never in all three.
    peak = min(peak_after_the_first_frame() for _ in range(3))
    # Zarr holds a few buffers per chunk read (compressed, decoded, output); what matters
    # is that the peak does not grow with the number of frames.
    assert peak < 5 * frame_bytes < (n - 1) * frame_bytes / 2, f"peak {peak} B"
    assert [int(f[0, 0]) for f in session.iter_frames([3, 1])] == [
        int(session.read_frame(3)[0, 0]),
        int(session.read_frame(1)[0, 0]),
    ]


def test_float_and_odd_dtypes_round_trip(rig_description, data, make_frame):
    plan = Plan("f", [Step("spectral", "led", 0.1, {"kind": "full"})] * 2)
    session = new_session(rig_description, plan, data)
    base = make_frame()
    pixels = np.linspace(0, 1, 48, dtype=np.float32).reshape(6, 8)
    session.write_frame(0, type(base)(pixels, base.meta))
    np.testing.assert_array_equal(session.read_frame(0), pixels)
    assert session.verify() == 1


def test_frames_are_byte_shuffled_and_stores_of_an_earlier_codec_still_read(tmp_path):
    from numcodecs import Zstd
    from zarr.codecs import ZstdCodec

    rng = np.random.default_rng(2)
    mean_e = np.full((256, 400), 30.0)
    mean_e[:, ::20] = 3000.0  # bright streaks on a dark, noisy frame, as a scan frame
    frame = (rng.poisson(mean_e) + 100).astype(np.uint16)
    FrameStore.create(tmp_path, {"session": "codec"})
    store = FrameStore(tmp_path, {"spectral": [0]})
    store.write("spectral", 0, frame, replace_ok=True, where="test")
    meta = json.loads((tmp_path / "frames.zarr" / "spectral" / "zarr.json").read_text())
    assert meta["codecs"][1]["configuration"]["shuffle"] == "shuffle"
    plain = len(Zstd(level=3).encode(frame.tobytes()))
    assert store.chunk_file("spectral", 0).stat().st_size < 0.9 * plain
    # A store written with plain zstd (the earlier codec) reads through the same code.
    old = tmp_path / "old"
    FrameStore.create(old, {"session": "old"})
    zarr.open_group(old / "frames.zarr", mode="r+").create_array(
        "spectral", shape=(1, *frame.shape), chunks=(1, *frame.shape), dtype=frame.dtype,
        compressors=ZstdCodec(level=3), attributes={"camera": "spectral", "steps": [0]},
    )[0] = frame  # fmt: skip
    record = {"shape": list(frame.shape), "sha256": frame_sha256(frame)}  # no checksum then
    assert np.array_equal(FrameStore(old, {"spectral": [0]}).read("spectral", 0, record), frame)
