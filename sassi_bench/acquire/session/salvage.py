"""What is left of a session that does not open: which of its files cannot be read, and
what its frames and event log still hold.

A session is three parts that check one another (``session.json``, ``events.jsonl``,
``frames.zarr``). When the header or the log is damaged, :func:`examine` reads each part on
its own, as far as it goes, so the error, ``sassi-bench data list`` and a resume can say
what is unreadable and what survives: each logged frame's step, camera, pattern, light,
exposure, tags and hashes, the chunk files, and the plan's SHA-256 that ``frames.zarr``
recorded when the session was made (a restored ``session.json`` must match it).

Examples
--------
>>> import tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> _ = (folder / "session.json").write_text('{"schema": "sassi-bench/sess')
>>> _ = (folder / "events.jsonl").write_text('{"step": 0, "camera": "spectral"}\\n')
>>> condition = examine(folder)
>>> condition.readable, condition.events
(False, 1)
>>> print(condition.unreadable())  # doctest: +NORMALIZE_WHITESPACE
session.json is not JSON (Unterminated string starting at: line 1 column 12 (char 11));
frames.zarr/zarr.json is missing
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sassi_bench.acquire.session.errors import SessionError, session_error
from sassi_bench.acquire.session.events import EVENTS_FILE, RETAKES_FILE
from sassi_bench.acquire.session.frames import FRAMES_DIR, FrameStore
from sassi_bench.acquire.session.header import SESSION_FILE, parse_header

__all__ = ["SessionCondition", "check_logged_frames", "examine"]


@dataclass(frozen=True)
class SessionCondition:
    """What :func:`examine` found in a session folder.

    Attributes
    ----------
    folder
        The session folder.
    header, log, frames
        What is wrong with ``session.json``, ``events.jsonl`` and ``frames.zarr`` (None:
        that part reads).
    events
        Event lines that read: each one a stored frame's step, camera, slot, pattern,
        light, exposure, tags, SHA-256 and checksum.
    damaged_lines
        Line numbers (from 1) of event lines that do not read, a torn last line excluded
        (an interrupted append, repaired on resume).
    chunks
        Chunk files under ``frames.zarr``.
    plan_sha256
        The plan's SHA-256 that ``frames.zarr`` recorded when the session was made.
    """

    folder: Path
    header: str | None
    log: str | None
    frames: str | None
    events: int
    damaged_lines: tuple[int, ...]
    chunks: int
    plan_sha256: str | None

    @property
    def readable(self) -> bool:
        """Whether the header and the log read (frames are checked as they are read)."""
        return self.header is None and self.log is None and self.frames is None

    def unreadable(self) -> str:
        """What cannot be read, in words ("" when everything reads)."""
        return "; ".join(p for p in (self.header, self.log, self.frames) if p is not None)

    def salvage(self) -> str:
        """What the frames and the log still hold, what can be rebuilt from them, and what
        cannot, in words."""
        held = (
            f"what is left: {self.chunks} frame chunk files in {FRAMES_DIR} and "
            f"{self.events} readable frame events in {EVENTS_FILE}, each with its step, "
            "camera, pattern, light, exposure, tags and hashes: the frames can be checked "
            "against them (`data verify`)"
        )
        parts = [held]
        if self.header is not None:
            recorded = (
                f"; a restored {SESSION_FILE} must hash its plan to {self.plan_sha256[:12]}, "
                f"as {FRAMES_DIR} recorded"
                if self.plan_sha256
                else ""
            )
            parts.append(
                "the captured steps of the plan can be rebuilt from the log; the rig "
                f"description and the plan's name, parameters and uncaptured steps cannot"
                f"{recorded}"
            )
        if self.damaged_lines:
            lines = ", ".join(str(n) for n in self.damaged_lines[:5])
            more = " ..." if len(self.damaged_lines) > 5 else ""
            parts.append(
                f"the frames of the damaged event lines ({lines}{more}) are in {FRAMES_DIR}, "
                "but their hashes and metadata cannot be rebuilt"
            )
        return "; ".join(parts)


def examine(folder: Path) -> SessionCondition:
    """Read each part of the session in ``folder`` on its own, as far as it goes.

    Parameters
    ----------
    folder
        A session folder, whole or damaged.

    Returns
    -------
    SessionCondition
    """
    header, header_problem = _header(folder)
    events, damaged, log_problem = _events(folder, header)
    frames_problem, chunks, plan_sha256 = _frames(folder)
    return SessionCondition(
        folder, header_problem, log_problem, frames_problem, events, damaged, chunks, plan_sha256
    )


def check_logged_frames(
    folder: Path, on_frame: Callable[[int], None] | None = None
) -> tuple[int, list[str]]:
    """Check each frame that a readable event line logs, without the session's header.

    What a session whose ``session.json`` is damaged can still be checked for: each
    logged frame is read from ``frames.zarr`` and checked against its event (checksum and
    SHA-256). A step logged twice is checked against its later event; events set aside
    for a retake are skipped.

    Parameters
    ----------
    folder
        The session folder.
    on_frame
        Called with each step once its frame is checked.

    Returns
    -------
    tuple of (int, list of str)
        Frames checked, and one line per frame found missing or damaged.

    Raises
    ------
    SessionError
        If ``frames.zarr`` or the event log cannot be opened at all.
    """
    try:
        raw = (folder / EVENTS_FILE).read_bytes()
        store = FrameStore(folder, {})
    except Exception as exc:  # zarr's own errors for a store it cannot open
        raise session_error(
            f"session {folder.name!r} check",
            f"its frames cannot be checked ({type(exc).__name__}: {exc})",
            "restore the session folder from a backup",
        ) from exc
    aside = set()
    with contextlib.suppress(OSError):
        for body in (folder / RETAKES_FILE).read_bytes().splitlines():
            with contextlib.suppress(ValueError, KeyError, TypeError):
                record = json.loads(body)
                aside.add((record["step"], record["sha256"], record.get("written")))
    events: dict[int, dict[str, Any]] = {}
    for body in raw.split(b"\n"):
        with contextlib.suppress(UnicodeDecodeError, ValueError, KeyError, TypeError):
            event = json.loads(body.decode("utf-8"))
            if (event["step"], event["sha256"], event.get("written")) not in aside:
                events[int(event["step"])] = event
    problems = []
    for step in sorted(events):
        event = events[step]
        try:
            camera, slot = str(event["camera"]), int(event["slot"])
            if store.array(camera) is None:
                problems.append(f"step {step}: {FRAMES_DIR}/{camera} is missing")
                continue
            problem = store.inspect(camera, slot, event)
        except (KeyError, TypeError, ValueError) as exc:
            problems.append(f"step {step}: its event lacks what a check needs ({exc})")
            continue
        if problem is not None:
            chunk = store.chunk_file(camera, slot).relative_to(folder).as_posix()
            problems.append(f"step {step}: the {camera} frame (slot {slot}, {chunk}) is {problem}")
        if on_frame is not None:
            on_frame(step)
    return len(events), problems


def _cause(exc: Exception) -> str:
    """The cause part of a ``step: cause. Fix: fix`` message."""
    text = str(exc).split(". Fix: ", 1)[0]
    return text.split(": ", 1)[1] if ": " in text else text


def _header(folder: Path) -> tuple[dict[str, Any] | None, str | None]:
    file = folder / SESSION_FILE
    try:
        raw = file.read_bytes()
    except FileNotFoundError:
        return None, f"{SESSION_FILE} is missing"
    except OSError as exc:
        return None, f"{SESSION_FILE} cannot be read ({exc})"
    try:
        return parse_header(raw, Path(SESSION_FILE)), None
    except SessionError as exc:
        return None, _cause(exc)


def _events(folder: Path, header: dict[str, Any] | None) -> tuple[int, tuple[int, ...], str | None]:
    """Readable event lines, damaged line numbers (a torn last line excluded), problem."""
    try:
        raw = (folder / EVENTS_FILE).read_bytes()
    except FileNotFoundError:
        return 0, (), f"{EVENTS_FILE} is missing"
    except OSError as exc:
        return 0, (), f"{EVENTS_FILE} cannot be read ({exc})"
    pieces = raw.split(b"\n")
    if pieces[-1] == b"":
        pieces.pop()  # a complete log ends with a line end
    good, damaged, reason = 0, [], ""
    steps = len(header["plan"]["steps"]) if header is not None else None
    for k, body in enumerate(pieces):
        why = _event_problem(body, steps)
        if why is None:
            good += 1
        elif k < len(pieces) - 1:  # a bad last line is a torn append, not damage
            damaged.append(k + 1)
            reason = reason or why
    problem = None
    if damaged:
        shown = ", ".join(str(n) for n in damaged[:5]) + (" ..." if len(damaged) > 5 else "")
        lines = f"line{'s' if len(damaged) > 1 else ''} {shown}"
        problem = f"{EVENTS_FILE} {lines} {'are' if len(damaged) > 1 else 'is'} damaged ({reason})"
    return good, tuple(damaged), problem


def _event_problem(body: bytes, steps: int | None) -> str | None:
    """Why an event line does not read (None: it does)."""
    try:
        event = json.loads(body.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        return f"not JSON: {exc}"
    if not isinstance(event, dict) or not isinstance(event.get("step"), int):
        return "not an event"
    if steps is not None and not 0 <= event["step"] < steps:
        return f"step {event['step']} is not a step of the plan"
    return None


def _frames(folder: Path) -> tuple[str | None, int, str | None]:
    root = folder / FRAMES_DIR
    try:
        group = json.loads((root / "zarr.json").read_bytes())
        plan_sha256 = group.get("attributes", {}).get("plan_sha256")
        problem = None
    except FileNotFoundError:
        plan_sha256, problem = None, f"{FRAMES_DIR}/zarr.json is missing"
    except (OSError, ValueError, AttributeError) as exc:
        plan_sha256, problem = None, f"{FRAMES_DIR}/zarr.json cannot be read ({exc})"
    chunks = sum(1 for p in root.glob("*/c/**/*") if p.is_file()) if root.is_dir() else 0
    return problem, chunks, plan_sha256 if isinstance(plan_sha256, str) else None
