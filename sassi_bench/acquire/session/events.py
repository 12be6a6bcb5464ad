"""``events.jsonl``: the append-only log of a session's stored frames.

One canonical-JSON line per stored frame, appended and fsync'd after its frame, so an
event exists only for a fully written frame; a step is *completed* when its event is in
the log. A torn last line (a crash while appending) is ignored, reported, and moved to
``events.torn`` before the next append; its step is simply captured again. A damaged line
before the last is an integrity error. A step logged twice keeps its later event.

A frame found damaged can be *set aside* (:meth:`EventLog.set_aside`): a line in
``retakes.jsonl`` names its event (step, SHA-256 and time written), and that event no
longer counts, so the step is captured again when the capture resumes; the retaken
frame's event, appended later, is the step's event from then on.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from numpy.typing import NDArray

from sassi_bench._shared.canonical_json import canonical_json
from sassi_bench.acquire.plan import PlanError, Step, to_json_value
from sassi_bench.acquire.session.errors import SessionIntegrityError, session_error
from sassi_bench.acquire.session.frames import CHECKSUM_KEY, frame_checksum, frame_sha256
from sassi_bench.acquire.session.header import utc_stamp
from sassi_bench.rig.frame import FrameMeta

__all__ = ["EVENTS_FILE", "RETAKES_FILE", "TORN_FILE", "EventLog", "frame_event"]

EVENTS_FILE = "events.jsonl"
TORN_FILE = "events.torn"
#: The events set aside for their frames to be captured again, one JSON line each.
RETAKES_FILE = "retakes.jsonl"

_EVENT_KEYS = ("step", "camera", "slot", "meta", "pattern", "tags", "sha256", "dtype", "shape")


def frame_event(
    step_index: int, step: Step, slot: int, data: NDArray[Any], meta: FrameMeta, where: str
) -> dict[str, Any]:
    """The event that logs a stored frame: its step, slot, metadata, pixel hash and time.

    Raises
    ------
    SessionError
        If the frame's metadata is not JSON.

    Examples
    --------
    >>> import numpy as np
    >>> step = Step("spectral", "off", 0.1, {"kind": "blank"})
    >>> meta = FrameMeta("spectral", 0.1, 0.0, 0, "off", 0)
    >>> event = frame_event(0, step, 0, np.zeros((2, 2), np.uint16), meta, "write")
    >>> event["dtype"], event["shape"], event["sha256"][:12], event["xxh3_64"]
    ('<u2', [2, 2], 'af5570f5a181', 'c77b3abb6f87acd9')
    """
    try:
        meta_json = to_json_value(meta.to_dict(), "frame.meta")
    except PlanError as exc:
        raise session_error(
            where,
            f"the frame metadata is not JSON ({exc})",
            "make the camera adapter put JSON values (str, numbers, lists, dicts) in "
            "FrameMeta.extra",
        ) from exc
    step_dict = step.to_dict()
    return {
        "step": step_index,
        "camera": step.camera,
        "slot": slot,
        "meta": meta_json,
        "pattern": step_dict["pattern"],
        "tags": step_dict["tags"],
        "sha256": frame_sha256(data),
        CHECKSUM_KEY: frame_checksum(data),
        "dtype": data.dtype.str,
        "shape": list(data.shape),
        "written": utc_stamp(datetime.now(UTC)),
    }


class EventLog:
    """The event log in ``folder``, read from disk when made.

    Parameters
    ----------
    folder
        The session folder (holding ``events.jsonl``).
    slots
        Per plan step, the ``(camera, slot)`` its frame is stored at; an event that
        disagrees is damaged.
    owner
        How error messages name the log's session, e.g. ``"session 's1'"``.

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> _ = (folder / EVENTS_FILE).write_bytes(b"")
    >>> log = EventLog(folder, [("spectral", 0), ("spectral", 1)], "session 'demo'")
    >>> event = {"step": 1, "camera": "spectral", "slot": 1, "meta": {}, "pattern": {},
    ...          "tags": {}, "sha256": "0" * 64, "dtype": "<u2", "shape": [2, 2]}
    >>> log.append(event)
    >>> log.completed, EventLog(folder, log.slots, "session 'demo'").event(1)["slot"]
    (frozenset({1}), 1)
    """

    def __init__(self, folder: Path, slots: Sequence[tuple[str, int]], owner: str) -> None:
        self._file = folder / EVENTS_FILE
        self._torn_file = folder / TORN_FILE
        self._retakes_file = folder / RETAKES_FILE
        self.slots = tuple(slots)
        self._owner = owner
        # step -> (raw line bytes incl. newline, parsed event)
        self._events: dict[int, tuple[bytes, dict[str, Any]]] = {}
        self._order: list[int] = []
        self._good_size = 0  # bytes of the log up to its last good line
        self._torn = b""
        self._problems: list[str] = []
        self.reload()

    @property
    def completed(self) -> frozenset[int]:
        """The steps whose events are logged."""
        return frozenset(self._events)

    @property
    def problems(self) -> tuple[str, ...]:
        """Recoverable problems found when the log was last read."""
        return tuple(self._problems)

    def __len__(self) -> int:
        return len(self._events)

    def __contains__(self, step: object) -> bool:
        return step in self._events

    def event(self, step: int) -> dict[str, Any]:
        """The logged event of ``step`` (the stored dict: copy it before handing it out)."""
        return self._events[step][1]

    def in_log_order(self) -> Iterator[dict[str, Any]]:
        """The logged events in the order they were appended (the stored dicts)."""
        return (self._events[step][1] for step in self._order)

    def lines_in_step_order(self) -> Iterator[bytes]:
        """The raw logged lines (newline included), by step."""
        return (self._events[step][0] for step in sorted(self._events))

    def changed_on_disk(self) -> bool:
        """Whether the log (or its retakes) grew or shrank since it was read (another
        writer appended)."""
        return (
            self._file.stat().st_size != self._good_size + len(self._torn)
            or _size(self._retakes_file) != self._retakes_size
        )

    @property
    def set_aside(self) -> tuple[dict[str, Any], ...]:
        """The retake records of events set aside (see :meth:`set_event_aside`)."""
        return tuple(self._retakes)

    def reload(self) -> None:
        """Read the log from disk again, forgetting what was read before."""
        self._events, self._order = {}, []
        self._good_size, self._torn, self._problems = 0, b"", []
        self._retakes_size = _size(self._retakes_file)
        self._retakes = self._read_retakes()
        aside = {_event_key(record) for record in self._retakes}
        lines = self._file.read_bytes().split(b"\n")
        # A complete log ends with a newline, leaving an empty last piece.
        tail = lines.pop()
        parsed = [(body + b"\n", *self._parse(body)) for body in lines]
        if tail:
            parsed.append((tail, None, "it has no line end"))
        for k, (line, event, reason) in enumerate(parsed):
            if event is None:
                if k < len(parsed) - 1:
                    raise session_error(
                        f"{self._owner} open",
                        f"{EVENTS_FILE} line {k + 1} is damaged ({reason})",
                        "restore the session from a backup; only a torn last line is "
                        "repaired automatically",
                        SessionIntegrityError,
                    )
                self._torn = line
                self._problems.append(
                    f"{EVENTS_FILE}: ignored a torn last line ({reason}; {len(line)} bytes), "
                    "left by an interrupted write; its step will be captured again"
                )
                break
            step = event["step"]
            self._good_size += len(line)
            if _event_key(event) in aside:
                self._events.pop(step, None)  # set aside: the step is to be captured again
                if step in self._order:
                    self._order.remove(step)
                continue
            if step in self._events:
                self._problems.append(
                    f"{EVENTS_FILE}: step {step} is logged twice; the later event is used "
                    "(run verify() to check the data)"
                )
                self._order.remove(step)
            self._events[step] = (line, event)
            self._order.append(step)

    def set_event_aside(self, step: int, reason: str, kept: str | None) -> dict[str, Any]:
        """Set the event of ``step`` aside so the step is captured again; the record of it.

        Parameters
        ----------
        step
            A logged step.
        reason
            Why (what was found wrong with its frame).
        kept
            Where its damaged chunk file was moved, relative to the session folder (None:
            there was none).
        """
        event = self._events[step][1]
        record = {
            "step": step,
            "sha256": event["sha256"],
            "written": event.get("written"),
            "reason": reason,
            "kept": kept,
            "set_aside": utc_stamp(datetime.now(UTC)),
        }
        line = canonical_json(record) + b"\n"
        _append_synced(self._retakes_file, line)
        self._retakes_size += len(line)
        self._retakes.append(record)
        del self._events[step]
        self._order.remove(step)
        return record

    def _read_retakes(self) -> list[dict[str, Any]]:
        """The retake records on disk. A damaged line (a crash while appending) is ignored
        and reported: its event then still counts, and its frame, already moved aside,
        reads as missing until it is set aside again."""
        try:
            raw = self._retakes_file.read_bytes()
        except FileNotFoundError:
            return []
        records = []
        for k, body in enumerate(raw.split(b"\n")):
            if not body.strip():
                continue
            try:
                record = json.loads(body.decode("utf-8"))
                _event_key(record)
            except (UnicodeDecodeError, ValueError, KeyError, TypeError):
                self._problems.append(f"{RETAKES_FILE}: line {k + 1} is damaged and ignored")
                continue
            records.append(record)
        return records

    def append(self, event: dict[str, Any]) -> None:
        """Append ``event`` as one canonical-JSON line and fsync it.

        A torn last line is first kept aside in ``events.torn`` and cut off, so the new line
        starts on a line of its own.

        Raises
        ------
        SessionError
            If the file changed on disk since it was read (another writer).
        """
        line = canonical_json(event) + b"\n"
        if self._file.stat().st_size != self._good_size:
            with open(self._file, "rb") as f:
                f.seek(self._good_size)
                torn = f.read()
            if torn != self._torn:
                raise session_error(
                    f"{self._owner} write",
                    f"{EVENTS_FILE} changed since the session was opened (another writer?)",
                    "write a session from one process only; open it again to see what is stored",
                )
            # Nothing is ever thrown away: the torn bytes go to events.torn first.
            _append_synced(self._torn_file, torn + b"\n")
            os.truncate(self._file, self._good_size)
            self._torn = b""
        _append_synced(self._file, line)
        self._good_size += len(line)
        step = event["step"]
        self._events[step] = (line, event)
        self._order.append(step)

    def _parse(self, body: bytes) -> tuple[dict[str, Any] | None, str]:
        try:
            event = json.loads(body.decode("utf-8"))
        except (UnicodeDecodeError, ValueError) as exc:
            return None, f"not JSON: {exc}"
        if not isinstance(event, dict) or any(key not in event for key in _EVENT_KEYS):
            return None, "missing event keys"
        step = event["step"]
        if not isinstance(step, int) or not 0 <= step < len(self.slots):
            return None, f"step {step!r} is not a step of the plan"
        if (event["camera"], event["slot"]) != self.slots[step]:
            return None, f"step {step}'s camera or slot disagrees with the plan"
        return event, ""


def _size(file: Path) -> int:
    try:
        return file.stat().st_size
    except FileNotFoundError:
        return 0


def _event_key(event: dict[str, Any]) -> tuple[int, str, str | None]:
    """What names one logged event: its step, frame hash and time written."""
    return int(event["step"]), str(event["sha256"]), event.get("written")


def _append_synced(file: Path, data: bytes) -> None:
    with open(file, "ab") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
