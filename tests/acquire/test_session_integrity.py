"""Every read of a stored frame is checked against what its session recorded: a chunk
deleted, truncated or edited is named (session, step, frame file, what is wrong), never
read as Zarr's fill value; damaged frames can be set aside and captured again."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.session import FrameDamagedError, Session, SessionWarning
from sassi_bench.acquire.session.errors import SessionDamagedError
from sassi_bench.acquire.session.events import RETAKES_FILE
from sassi_bench.acquire.session.salvage import check_logged_frames


@pytest.fixture()
def session(rig_description, pinhole_step, make_frame, data) -> Session:
    """Five stored spectral frames of distinct, noisy pixels (steps 0-4)."""
    plan = Plan("five", [pinhole_step(k) for k in range(5)])
    made = Session.create(rig_description, plan, session_id="s1", data=data)
    rng = np.random.default_rng(1)
    for i in range(5):
        frame = make_frame(shape=(32, 48), index=i)
        pixels = rng.integers(100, 4000, (32, 48), dtype=np.uint16)
        made.write_frame(i, type(frame)(pixels, frame.meta))
    return made


def chunk(session: Session, step: int):
    return session.path / "frames.zarr" / "spectral" / "c" / str(step) / "0" / "0"


def test_reads_name_a_deleted_chunk_rather_than_return_zeros(session):
    chunk(session, 3).unlink()
    reopened = Session.open("s1", data=session.path.parents[1])
    with pytest.raises(FrameDamagedError) as caught:
        reopened.read_frame(3)
    message = str(caught.value)
    assert message.startswith("session 's1' read step 3: the spectral frame (slot 3, ")
    assert "frames.zarr/spectral/c/3/0/0) is missing: its chunk file is gone" in message
    assert "Fix: nothing is computed from a damaged frame" in message
    assert "sassi-bench data verify s1 --retake" in message
    damage = caught.value.damage
    assert (damage.step, damage.camera, damage.slot, damage.kind) == (3, "spectral", 3, "missing")
    for read in (
        lambda: reopened.read_frames([0, 3, 4]),
        lambda: list(reopened.iter_frames([2, 3])),
    ):
        with pytest.raises(FrameDamagedError, match="read step 3: "):
            read()
    assert reopened.read_frames([0, 4]).shape == (2, 32, 48)  # the others still read


def test_reads_name_a_truncated_chunk(session):
    file = chunk(session, 1)
    stored = file.stat().st_size
    file.write_bytes(file.read_bytes()[:100])
    with pytest.raises(FrameDamagedError, match=rf"read step 1: .* is truncated: its chunk file "
                       rf"is 100 bytes, {stored} were stored; it does not decode"):  # fmt: skip
        session.read_frame(1)


def test_reads_name_a_flipped_byte(session):
    file = chunk(session, 2)
    raw = bytearray(file.read_bytes())
    raw[len(raw) // 2] ^= 0x01
    file.write_bytes(bytes(raw))
    with pytest.raises(FrameDamagedError, match=r"read step 2: .* is (changed|unreadable): "):
        session.read_frame(2)
    assert session.find_damage(thorough=False) == [], "the size alone cannot see a flipped bit"
    (found,) = session.find_damage()
    assert found.step == 2 and found.kind in ("changed", "unreadable")


def test_the_quick_check_sees_deleted_and_truncated_chunks_without_reading(session):
    chunk(session, 0).unlink()
    file = chunk(session, 4)
    file.write_bytes(file.read_bytes()[:-7])
    found = session.find_damage(thorough=False)
    assert [(d.step, d.kind) for d in found] == [(0, "missing"), (4, "truncated")]
    with pytest.raises(FrameDamagedError, match=r"verify step 0: .*\(1 more frames are damaged\)"):
        session.verify()


def test_a_session_logged_before_the_checksum_is_checked_against_its_sha256(session):
    log = session.path / "events.jsonl"
    events = [json.loads(line) for line in log.read_text().splitlines()]
    for event in events:
        del event["xxh3_64"], event["stored_bytes"]
    log.write_text("".join(json.dumps(e, sort_keys=True) + "\n" for e in events))
    old = Session.open("s1", data=session.path.parents[1])
    assert old.read_frames(range(5)).shape == (5, 32, 48) and old.verify() == 5
    chunk(session, 3).unlink()
    with pytest.raises(FrameDamagedError, match=r"read step 3: .* is missing"):
        old.read_frame(3)


def test_set_aside_keeps_the_damaged_chunk_and_the_capture_takes_the_step_again(
    session, make_frame
):
    file = chunk(session, 2)
    file.write_bytes(file.read_bytes()[:50])
    damaged = file.read_bytes()
    (record,) = session.set_aside(session.find_damage())
    assert record["step"] == 2 and record["reason"].startswith("truncated: ")
    assert (session.path / record["kept"]).read_bytes() == damaged, "kept as found"
    assert not file.exists() and session.missing == (2,)
    data = session.path.parents[1]
    again = Session.open("s1", data=data)
    assert again.missing == (2,) and again.set_aside_frames[0]["kept"] == record["kept"]
    retaken = make_frame(shape=(32, 48), value=9, index=2)
    again.write_frame(2, retaken)  # as a resumed capture stores it
    with warnings.catch_warnings():
        warnings.simplefilter("error", SessionWarning)  # no "logged twice" warning
        reopened = Session.open("s1", data=data)
    assert reopened.is_complete and reopened.verify() == 5
    np.testing.assert_array_equal(reopened.read_frame(2), retaken.data)
    assert len((session.path / RETAKES_FILE).read_text().splitlines()) == 1
    assert reopened.sha256() != session.sha256()  # another frame: another content hash


# -- a damaged header or log -------------------------------------------------------------
@pytest.mark.parametrize("damage", ["truncated", "deleted"])
def test_a_damaged_header_is_named_with_what_the_frames_and_log_still_hold(
    session, rig_description, damage
):
    header = session.path / "session.json"
    if damage == "truncated":
        header.write_bytes(header.read_bytes()[:300])
        cause = "session.json is not JSON ("
    else:
        header.unlink()
        cause = "session.json is missing"
    data, plan = session.path.parents[1], session.plan
    attempts = {
        "open": lambda: Session.open("s1", data=data),
        "resume": lambda: Session.open_or_create(rig_description, plan, session_id="s1", data=data),
        "resume or plan": lambda: Session.resume_or_plan(
            rig_description, lambda: pytest.fail("planned anew"), session_id="s1", data=data
        ),
    }  # fmt: skip
    for attempt in attempts.values():
        with pytest.raises(SessionDamagedError) as caught:
            attempt()
        message = str(caught.value)
        assert message.startswith(f"session 's1' open: {cause}")
        assert "5 readable frame events in events.jsonl" in message
        assert "5 frame chunk files in frames.zarr" in message
        assert f"hash its plan to {plan.sha256()[:12]}" in message
        assert "already exists" not in message and "restore session.json" in message
    assert check_logged_frames(session.path) == (5, [])
    chunk(session, 1).unlink()
    checked, problems = check_logged_frames(session.path)
    assert checked == 5 and len(problems) == 1
    assert problems[0].startswith(
        "step 1: the spectral frame (slot 1, frames.zarr/spectral/c/1/0/0)"
    )
    assert "is missing" in problems[0]


@pytest.mark.parametrize("field", ["xxh3_64", "sha256"])
def test_a_damaged_hash_in_the_log_is_told_from_a_damaged_frame(session, field):
    log = session.path / "events.jsonl"
    events = [json.loads(line) for line in log.read_text().splitlines()]
    events[2][field] = "0" * len(events[2][field])
    log.write_text("".join(json.dumps(e, sort_keys=True) + "\n" for e in events))
    reopened = Session.open("s1", data=session.path.parents[1])
    reopened.read_frame(2)  # the pixels are the frame stored: reads go on
    (found,) = reopened.find_damage()
    assert found.kind == "mislogged" and "the event line is damaged, not the frame" in found.detail


def test_a_real_bench_s_session_opens_again(pinhole_step, data):
    """A hardware rig's identity leaves out where its devices are plugged in; the stored
    header is checked by the same rule, so its sessions are not read as damaged."""
    from sassi_bench.rig import load_rig_description

    lab = load_rig_description("lab-example")
    plan = Plan("one", [pinhole_step(0)])
    created = Session.create(lab, plan, session_id="bench", data=data)
    assert Session.open("bench", data=data).rig_sha256 == lab.sha256() == created.rig_sha256
