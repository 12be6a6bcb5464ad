"""The :class:`Session`: a raw capture session's header, event log, frames and write lock
put together (the layout is described in :mod:`sassi_bench.acquire.session`).

It creates, opens and resumes sessions, writes each frame then its event under the write
lock, and reads frames back, each checked against its event as it is read: a frame that
is missing or damaged raises :class:`FrameDamagedError` naming the session, the step, the
frame's file and what is wrong, so nothing is ever computed from it. :meth:`Session.verify`
checks every frame on demand; :meth:`Session.set_aside` moves damaged frames out of the
way so that resuming the capture takes them again.
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import os
import warnings
from collections.abc import Callable, Iterable, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench._shared.atomic import atomic_write_bytes, fsync_dir
from sassi_bench._shared.canonical_json import canonical_json
from sassi_bench._shared.lock import LockHeldError, WriteLock
from sassi_bench._shared.signals import deferred_stop_signals
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.session.errors import (
    FrameDamage,
    FrameDamagedError,
    SessionDamagedError,
    SessionError,
    SessionIntegrityError,
    SessionLockedError,
    SessionWarning,
    session_error,
)
from sassi_bench.acquire.session.events import EVENTS_FILE, EventLog, frame_event
from sassi_bench.acquire.session.folder import (
    LOCK_FILE,
    create_session_folder,
    find_session,
    read_header,
    session_folder,
)
from sassi_bench.acquire.session.frames import (
    FRAMES_DIR,
    STORED_BYTES_KEY,
    FrameProblem,
    FrameStore,
    check_frame,
)
from sassi_bench.acquire.session.header import SESSION_FILE, check_resumable, utc_stamp
from sassi_bench.acquire.session.salvage import examine
from sassi_bench.errors import step_error
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.frame import Frame

__all__ = ["DAMAGED_DIR", "VERIFY_FILE", "Session"]

#: Folder of a session where frames set aside are kept (see :meth:`Session.set_aside`).
DAMAGED_DIR = "damaged"
#: The record of a session's last full check (see :meth:`Session.record_verification`).
VERIFY_FILE = "verify.json"


def _headless_folder(
    path_or_id: str | os.PathLike[str], data: str | os.PathLike[str] | None
) -> Path | None:
    """A session folder whose ``session.json`` is gone but whose log or frames are there."""
    candidates = [Path(path_or_id)]
    with contextlib.suppress(SessionError):
        candidates.insert(0, session_folder(str(path_or_id), data))
    for folder in candidates:
        if (folder / EVENTS_FILE).is_file() or (folder / FRAMES_DIR).is_dir():
            return folder
    return None


def _damaged_session(path: Path, exc: BaseException) -> SessionDamagedError:
    """The error for a session whose header, log or frame store cannot be read: what is
    unreadable, and what its frames and log still hold."""
    condition = examine(path)
    unreadable = condition.unreadable() or str(exc).split(". Fix: ", 1)[0]
    parts = [
        name for name, bad in ((SESSION_FILE, condition.header), (EVENTS_FILE, condition.log),
                               (FRAMES_DIR, condition.frames)) if bad
    ]  # fmt: skip
    restore = " and ".join(parts) or "the session folder"
    message = step_error(
        f"session {path.name!r} open",
        f"{unreadable}; {condition.salvage()}",
        f"the session is kept as it is (`sassi-bench data clean` leaves damaged sessions "
        f"alone); restore {restore} from a backup to use it again, or capture into a new "
        f"session id. `sassi-bench data verify {path.name}` checks its frames against the log",
    )
    return SessionDamagedError(message, condition)


def _camera_slots(plan: Plan) -> tuple[dict[str, list[int]], list[tuple[str, int]]]:
    """Per camera, the plan step of each array slot; per step, its camera and slot."""
    steps: dict[str, list[int]] = {camera: [] for camera in plan.cameras}
    slots = []
    for i, step in enumerate(plan.steps):
        slots.append((step.camera, len(steps[step.camera])))
        steps[step.camera].append(i)
    return steps, slots


class Session:
    """A raw capture session on disk (see :mod:`sassi_bench.acquire.session` for the layout).

    Use :meth:`create`, :meth:`open` or :meth:`open_or_create`; the constructor is
    private.
    """

    def __init__(self, path: Path, header: dict[str, Any], header_bytes: bytes) -> None:
        self._path = path
        self._header = header
        self._header_bytes = header_bytes
        self._plan = Plan.from_dict(header["plan"])
        steps_of_camera, slots = _camera_slots(self._plan)
        try:
            self._frames = FrameStore(path, steps_of_camera)
        except Exception as exc:  # whatever zarr raises for a store it cannot open
            raise session_error(
                f"session {self.id!r} open",
                f"{FRAMES_DIR} cannot be opened ({type(exc).__name__}: {exc})",
                "restore the session folder from a backup",
                SessionIntegrityError,
            ) from exc
        self._log = EventLog(path, slots, f"session {self.id!r}")
        self._lock = WriteLock(path / LOCK_FILE)
        self._warn_problems(stacklevel=3)  # at the caller of open/create

    # -- creating and opening ---------------------------------------------------------
    @classmethod
    def create(
        cls,
        rig_description: RigDescription,
        plan: Plan,
        *,
        session_id: str | None = None,
        data: str | os.PathLike[str] | None = None,
    ) -> Session:
        """Create a new, empty session for ``plan`` on the rig ``rig_description``.

        Parameters
        ----------
        rig_description
            The rig the frames will come from (``rig.description``).
        plan
            What will be captured.
        session_id
            Folder name under ``<data>/sessions/``; letters, digits, ``.``, ``_``, ``-``.
            Default: ``<UTC time>-<plan name>``, e.g. ``20250101T120000Z-gray-532``.
        data
            Data root (see :func:`sassi_bench.paths.data_root`).

        Returns
        -------
        Session

        Raises
        ------
        SessionError
            If a session with this id exists (it is never overwritten).

        Examples
        --------
        >>> import tempfile
        >>> tmp = tempfile.TemporaryDirectory()
        >>> from sassi_bench.acquire.plan import Plan, Step
        >>> from sassi_bench.rig import load_rig_description
        >>> plan = Plan("dark", [Step("spectral", "off", 0.1, {"kind": "blank"})])
        >>> s = Session.create(load_rig_description("sim"), plan, session_id="d",
        ...                    data=tmp.name)
        >>> s.id, s.is_complete, sorted(p.name for p in s.path.iterdir())
        ('d', False, ['events.jsonl', 'frames.zarr', 'session.json'])
        >>> tmp.cleanup()
        """
        return cls(*create_session_folder(rig_description, plan, session_id, data))

    @classmethod
    def open(
        cls, path_or_id: str | os.PathLike[str], *, data: str | os.PathLike[str] | None = None
    ) -> Session:
        """Open an existing session by folder path or by id under ``<data>/sessions/``.

        Raises
        ------
        SessionDamagedError
            If its ``session.json``, event log or frame store cannot be read: the message
            says what is unreadable and what the frames and the log still hold.
        SessionError
            If there is no session there.

        Examples
        --------
        >>> import tempfile
        >>> tmp = tempfile.TemporaryDirectory()
        >>> from sassi_bench.acquire.plan import Plan, Step
        >>> from sassi_bench.rig import load_rig_description
        >>> root = tmp.name
        >>> plan = Plan("dark", [Step("spectral", "off", 0.1, {"kind": "blank"})])
        >>> s = Session.create(load_rig_description("sim"), plan, session_id="d", data=root)
        >>> Session.open("d", data=root).plan == plan, Session.open(s.path).id
        (True, 'd')
        >>> tmp.cleanup()
        """
        try:
            path = find_session(path_or_id, data)
        except SessionError:
            path = _headless_folder(path_or_id, data)
            if path is None:
                raise
        try:
            return cls(path, *read_header(path))
        except (SessionIntegrityError, OSError) as exc:
            raise _damaged_session(path, exc) from exc

    @classmethod
    def resume_or_plan(
        cls,
        rig_description: RigDescription,
        make_plan: Callable[[], Plan],
        *,
        session_id: str,
        data: str | os.PathLike[str] | None = None,
    ) -> Session:
        """Resume session ``session_id`` with its stored plan, or create it from ``make_plan()``.

        ``make_plan`` is called only for a new session: planning may run auto-exposure
        on the devices, which a resumed capture must not repeat (nor change).

        Examples
        --------
        >>> import tempfile
        >>> tmp = tempfile.TemporaryDirectory()
        >>> from sassi_bench.acquire.plan import Plan, Step
        >>> from sassi_bench.rig import load_rig_description
        >>> root, rig = tmp.name, load_rig_description("sim")
        >>> plan = lambda: Plan("dark", [Step("spectral", "off", 0.1, {"kind": "blank"})])
        >>> a = Session.resume_or_plan(rig, plan, session_id="d", data=root)
        >>> b = Session.resume_or_plan(rig, lambda: 1 / 0, session_id="d", data=root)
        >>> a.path == b.path
        True
        >>> tmp.cleanup()
        """
        try:
            existing = cls.open(session_id, data=data)
        except SessionDamagedError:
            raise  # never planned anew over a session that is there but damaged
        except SessionError:
            existing = None  # planned outside the handler: its errors are not chained to this
        if existing is None:
            return cls.create(rig_description, make_plan(), session_id=session_id, data=data)
        return cls.open_or_create(rig_description, existing.plan, session_id=session_id, data=data)

    @classmethod
    def open_or_create(
        cls,
        rig_description: RigDescription,
        plan: Plan,
        *,
        session_id: str,
        data: str | os.PathLike[str] | None = None,
    ) -> Session:
        """Resume session ``session_id`` if it exists for the same plan and rig, else create it.

        Raises
        ------
        SessionError
            If the session exists but was made for another plan or rig; nothing is
            changed on disk.

        Examples
        --------
        >>> import tempfile
        >>> tmp = tempfile.TemporaryDirectory()
        >>> from sassi_bench.acquire.plan import Plan, Step
        >>> from sassi_bench.rig import load_rig_description
        >>> root, rig = tmp.name, load_rig_description("sim")
        >>> plan = Plan("dark", [Step("spectral", "off", 0.1, {"kind": "blank"})])
        >>> a = Session.open_or_create(rig, plan, session_id="d", data=root)
        >>> Session.open_or_create(rig, plan, session_id="d", data=root).path == a.path
        True
        >>> tmp.cleanup()
        """
        path = session_folder(session_id, data)
        if not path.exists():
            return cls.create(rig_description, plan, session_id=session_id, data=data)
        session = cls.open(path)
        check_resumable(session._header, rig_description, plan)
        return session

    # -- properties -------------------------------------------------------------------
    @property
    def id(self) -> str:
        """The session id (its folder name)."""
        return str(self._header["id"])

    @property
    def path(self) -> Path:
        """The session folder."""
        return self._path

    @property
    def created(self) -> str:
        """Creation time, UTC ISO 8601."""
        return str(self._header["created"])

    @property
    def plan(self) -> Plan:
        """The plan the session captures."""
        return self._plan

    @property
    def plan_sha256(self) -> str:
        """SHA-256 of the plan (:meth:`Plan.sha256`)."""
        return str(self._header["plan_sha256"])

    @property
    def rig(self) -> dict[str, Any]:
        """The rig description (a copy of ``RigDescription.to_dict()``)."""
        return copy.deepcopy(self._header["rig"])

    @property
    def rig_sha256(self) -> str:
        """SHA-256 of the rig description (:meth:`RigDescription.sha256`)."""
        return str(self._header["rig_sha256"])

    @property
    def problems(self) -> tuple[str, ...]:
        """Recoverable problems found when the session was opened (also warned about)."""
        return self._log.problems

    @property
    def completed(self) -> frozenset[int]:
        """Indices of the steps whose frames are stored."""
        return self._log.completed

    @property
    def missing(self) -> tuple[int, ...]:
        """Indices of the steps still to capture, in plan order."""
        return tuple(i for i in range(len(self._plan)) if i not in self._log)

    @property
    def is_complete(self) -> bool:
        """Whether every step of the plan is stored."""
        return len(self._log) == len(self._plan)

    def __repr__(self) -> str:
        return (
            f"Session({self.id!r}, plan={self._plan.name!r}, "
            f"{len(self._log)}/{len(self._plan)} frames, path={str(self._path)!r})"
        )

    # -- writing ----------------------------------------------------------------------
    @property
    def locked_for_writing(self) -> bool:
        """Whether this object holds the session's write lock."""
        return self._lock.held

    def lock_for_writing(self) -> None:
        """Take the session's write lock (held until :meth:`close` or process exit).

        The event log is read again once the lock is held if another writer added to it
        since this object read it, so the frames it stored count as completed.

        Raises
        ------
        SessionLockedError
            If another process or Session object holds it; the message names the
            holder's pid, host, command and start time.
        """
        if self._lock.held:
            return
        try:
            self._lock.acquire()
        except LockHeldError as exc:
            raise session_error(
                f"session {self.id!r} write",
                f"another writer holds the session ({exc.holder})",
                "let it finish or stop it, then resume; one process at a time may capture "
                "into a session (reading it is always fine)",
                SessionLockedError,
            ) from None
        if self._lock.held and self._log.changed_on_disk():
            self._log.reload()
            self._warn_problems(stacklevel=2)

    def close(self) -> None:
        """Release the write lock, if this object holds it (reading stays possible)."""
        self._lock.release()

    @contextlib.contextmanager
    def writing(self) -> Iterator[Session]:
        """Hold the write lock for a block (released at its end unless held before).

        Examples
        --------
        Not run here (it drives a bench or reads its sessions)::

            with session.writing():
                session.write_frame(0, frame)
        """
        held = self._lock.held
        self.lock_for_writing()
        try:
            yield self
        finally:
            if not held:
                self.close()

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def write_frame(self, step_index: int, frame: Frame) -> None:
        """Store the frame of step ``step_index``, then log its event.

        The chunk is written and fsync'd first; the event line is appended and fsync'd
        after, so a crash never leaves an event without its frame.

        The session's write lock is held while the frame is stored (for the whole run
        inside :meth:`writing`, as :func:`~sassi_bench.acquire.runner.run_plan` does).

        Raises
        ------
        SessionError
            For an index out of range, a completed step, a frame from the other camera,
            or a shape/dtype that differs from the camera's earlier frames.
        SessionLockedError
            If another writer holds the session.

        Examples
        --------
        See :mod:`sassi_bench.acquire.session`.
        """
        with self.writing():
            self._write_frame(step_index, frame)

    def _write_frame(self, step_index: int, frame: Frame) -> None:
        i = self._check_index(step_index)
        step = self._plan.steps[i]
        where = f"session {self.id!r} write step {i}"
        if i in self._log:
            raise session_error(
                where,
                "this step is already stored (completed steps are never overwritten)",
                "capture into a new session (another session id) to retake it",
            )
        if not isinstance(frame, Frame):
            raise session_error(
                where, f"got a {type(frame).__name__}", "pass a Frame from a camera"
            )
        data = np.asarray(frame.data)
        check_frame(where, step.camera, frame.meta.camera, data)
        event = frame_event(i, step, self._log.slots[i][1], data, frame.meta, where)
        camera_logged = any(self._plan.steps[j].camera == step.camera for j in self._log.completed)
        event[STORED_BYTES_KEY] = self._frames.write(
            step.camera, event["slot"], data, replace_ok=not camera_logged, where=where
        )
        self._log.append(event)

    # -- reading ----------------------------------------------------------------------
    def read_frame(self, step_index: int) -> NDArray[Any]:
        """The stored frame of step ``step_index`` (a read-only array), checked against
        the checksum its event recorded.

        Raises
        ------
        FrameDamagedError
            If the frame is missing or damaged (naming the step, its file and how).

        Examples
        --------
        See :mod:`sassi_bench.acquire.session`.
        """
        i = self._check_index(step_index)
        camera, slot = self._locate(i, "read")
        try:
            out = self._frames.read(camera, slot, self._log.event(i))
        except FrameProblem as problem:
            raise self._damaged(i, camera, problem, "read") from None
        out.setflags(write=False)
        return out

    def read_frames(self, step_indices: Iterable[int]) -> NDArray[Any]:
        """Frames of several steps of one camera, stacked along a new first axis, each
        checked as :meth:`read_frame` checks it.

        Examples
        --------
        >>> import tempfile
        >>> tmp = tempfile.TemporaryDirectory()
        >>> from sassi_bench.acquire.plan import Plan, Step
        >>> from sassi_bench.rig import FrameMeta, Frame, load_rig_description
        >>> plan = Plan("p", [Step("spectral", "off", 1, {"kind": "blank"})] * 3)
        >>> s = Session.create(load_rig_description("sim"), plan, session_id="p",
        ...                    data=tmp.name)
        >>> for i in range(3):
        ...     s.write_frame(i, Frame(np.full((2, 2), i, np.uint16),
        ...                   FrameMeta("spectral", 1.0, 0.0, i, "off", i)))
        >>> s.read_frames([2, 0]).shape, s.read_frames([2, 0])[:, 0, 0].tolist()
        ((2, 2, 2), [2, 0])
        >>> tmp.cleanup()
        """
        indices = [self._check_index(i) for i in step_indices]
        if not indices:
            raise session_error("session read", "no step indices given", "pass at least one index")
        located = [self._locate(i, "read") for i in indices]
        cameras = {self._plan.steps[i].camera for i in indices}
        if len(cameras) > 1:
            raise session_error(
                f"session {self.id!r} read",
                f"steps {indices} mix cameras {sorted(cameras)}",
                "read each camera's steps separately (plan.select / step.camera)",
            )
        camera = located[0][0]
        try:
            out = self._frames.read_slots(
                camera, [slot for _, slot in located], [self._log.event(i) for i in indices]
            )
        except FrameProblem as problem:
            step = indices[[slot for _, slot in located].index(problem.slot)]
            raise self._damaged(step, camera, problem, "read") from None
        out.setflags(write=False)
        return out

    def iter_frames(self, step_indices: Iterable[int]) -> Iterator[NDArray[Any]]:
        """Yield the frames of ``step_indices`` one at a time (one chunk in memory).

        Examples
        --------
        >>> import tempfile
        >>> tmp = tempfile.TemporaryDirectory()
        >>> from sassi_bench.acquire.plan import Plan, Step
        >>> from sassi_bench.rig import FrameMeta, Frame, load_rig_description
        >>> plan = Plan("p", [Step("spectral", "off", 1, {"kind": "blank"})] * 2)
        >>> s = Session.create(load_rig_description("sim"), plan, session_id="p",
        ...                    data=tmp.name)
        >>> for i in range(2):
        ...     s.write_frame(i, Frame(np.full((2, 2), i, np.uint16),
        ...                   FrameMeta("spectral", 1.0, 0.0, i, "off", i)))
        >>> [int(f.sum()) for f in s.iter_frames([1, 0])]
        [4, 0]
        >>> tmp.cleanup()
        """
        for i in step_indices:
            yield self.read_frame(i)

    def events(self) -> list[dict[str, Any]]:
        """The stored frames' events, in log order (copies).

        Each has ``step``, ``camera``, ``slot``, ``meta`` (``FrameMeta.to_dict()``),
        ``pattern``, ``tags``, ``sha256`` (of the pixels), ``dtype`` (numpy ``str``),
        ``shape`` and ``written`` (UTC ISO 8601).
        """
        return [copy.deepcopy(event) for event in self._log.in_log_order()]

    def event(self, step_index: int) -> dict[str, Any]:
        """The event of one stored step (a copy)."""
        i = self._check_index(step_index)
        self._locate(i, "read")
        return copy.deepcopy(self._log.event(i))

    # -- identity and integrity -------------------------------------------------------
    def sha256(self) -> str:
        """SHA-256 over ``session.json`` and the completed steps' event lines in step order.

        Each event carries its frame's hash, so this identifies the session's content
        (for a bundle's ``inputs``). It changes when frames are added.
        """
        h = hashlib.sha256(self._header_bytes)
        for line in self._log.lines_in_step_order():
            h.update(line)
        return h.hexdigest()

    def verify(self, on_frame: Callable[[int], None] | None = None) -> int:
        """Check every stored frame: read whole, against its checksum and its SHA-256.

        Parameters
        ----------
        on_frame
            Called with each step once its frame is checked (a progress bar).

        Returns
        -------
        int
            Number of frames verified.

        Raises
        ------
        FrameDamagedError
            Naming the first damaged frame (and how many others are).
        """
        found = self.find_damage(on_frame=on_frame)
        if found:
            first = found[0]
            more = f" ({len(found) - 1} more frames are damaged)" if len(found) > 1 else ""
            raise self._damage_error(first, "verify", more)
        return len(self._log)

    def find_damage(
        self, *, thorough: bool = True, on_frame: Callable[[int], None] | None = None
    ) -> list[FrameDamage]:
        """Every stored frame that is missing or damaged, in step order.

        Parameters
        ----------
        thorough
            Read every frame and check it against its checksum and SHA-256; else look at
            the chunk files only (one ``stat`` each: a chunk gone or of another size than
            stored, where the event recorded it), which is quick.
        on_frame
            Called with each step once its frame is checked.

        Examples
        --------
        Not run here (it drives a bench or reads its sessions)::

            session.find_damage(thorough=False)
            # [FrameDamage(session=..., step=3, camera='spectral', ..., kind='missing', ...)]
        """
        found = []
        for i in sorted(self._log.completed):
            camera, slot = self._plan.steps[i].camera, self._log.slots[i][1]
            event = self._log.event(i)
            if thorough:
                problem = self._frames.inspect(camera, slot, event)
            else:
                problem = self._frames.quick_inspect(camera, slot, event)
            if problem is not None:
                found.append(self._damage(i, camera, problem))
            if on_frame is not None:
                on_frame(i)
        return found

    def record_verification(self, found: Iterable[FrameDamage]) -> Path:
        """Keep the outcome of a full check (:meth:`find_damage`) in ``verify.json``, so a
        listing can show the damage found without reading every frame again.

        Returns
        -------
        pathlib.Path
            The record's file.
        """
        damaged = [
            {
                "step": d.step,
                "sha256": self._log.event(d.step)["sha256"],
                "kind": d.kind,
                "detail": d.detail,
                "chunk": d.chunk.as_posix(),
            }
            for d in found
            if d.step in self._log
        ]
        record = {
            "checked": utc_stamp(datetime.now(UTC)),
            "frames": len(self._log),
            "damaged": damaged,
        }
        return atomic_write_bytes(self._path / VERIFY_FILE, canonical_json(record), overwrite=True)

    def last_verification(self) -> dict[str, Any] | None:
        """The record of the last full check, its ``damaged`` list cut to the frames that
        are still the ones checked (a frame set aside or captured again since is not);
        None when the session was never checked, or its record does not read."""
        try:
            record = json.loads((self._path / VERIFY_FILE).read_bytes())
            damaged = [
                d
                for d in record["damaged"]
                if d["step"] in self._log and self._log.event(d["step"])["sha256"] == d["sha256"]
            ]
        except (OSError, ValueError, KeyError, TypeError):
            return None
        return {**record, "damaged": damaged}

    @property
    def set_aside_frames(self) -> tuple[dict[str, Any], ...]:
        """The records of frames set aside (:meth:`set_aside`): step, SHA-256, reason,
        where the damaged chunk was kept, when."""
        return tuple(copy.deepcopy(r) for r in self._log.set_aside)

    def set_aside(self, damages: Iterable[FrameDamage]) -> list[dict[str, Any]]:
        """Set damaged frames aside, so that resuming the capture takes them again.

        Each frame's chunk file (when there is one) is moved to ``damaged/`` in the
        session folder, kept as found, and a line in ``retakes.jsonl`` sets its event
        aside: the step counts as not captured, and the capture's next run (the same
        command with the same session id) captures it again. Nothing is deleted.

        Raises
        ------
        SessionLockedError
            If another process is writing the session.

        Examples
        --------
        Not run here (it drives a bench or reads its sessions)::

            session.set_aside(session.find_damage())
        """
        records = []
        with self.writing():
            for damage in damages:
                if damage.step not in self._log:
                    continue  # set aside already
                with deferred_stop_signals():  # the move and its record go together
                    kept = self._keep_damaged(damage)
                    reason = f"{damage.kind}: {damage.detail}"
                    records.append(self._log.set_event_aside(damage.step, reason, kept))
        return records

    def _keep_damaged(self, damage: FrameDamage) -> str | None:
        """Move a damaged frame's chunk file into ``damaged/``; its new place, if any."""
        chunk = self._path / damage.chunk
        if not chunk.exists():
            return None
        stamp = utc_stamp(datetime.now(UTC)).replace(":", "").replace("-", "")
        kept = Path(DAMAGED_DIR) / damage.camera / f"slot{damage.slot}-step{damage.step}-{stamp}"
        (self._path / kept).parent.mkdir(parents=True, exist_ok=True)
        os.rename(chunk, self._path / kept)
        fsync_dir((self._path / kept).parent)
        fsync_dir(chunk.parent)
        return kept.as_posix()

    # -- internals --------------------------------------------------------------------
    def _check_index(self, step_index: int) -> int:
        n = len(self._plan)
        if isinstance(step_index, bool) or not isinstance(step_index, (int, np.integer)):
            raise session_error(
                f"session {self.id!r}",
                f"step index {step_index!r} is not an integer",
                "pass a step index (see plan.select)",
            )
        if not 0 <= step_index < n:
            raise session_error(
                f"session {self.id!r}",
                f"step index {step_index} is out of range (the plan has {n} steps)",
                f"use 0..{n - 1}",
            )
        return int(step_index)

    def _locate(self, i: int, action: str) -> tuple[str, int]:
        """The camera and slot of a logged step whose camera array exists."""
        camera = self._plan.steps[i].camera
        where = f"session {self.id!r} {action} step {i}"
        if i not in self._log:
            raise session_error(
                where,
                "this step was never captured",
                "run the plan to capture it (run_plan resumes where it stopped); "
                "session.missing lists what is left",
            )
        if self._frames.array(camera) is None:
            raise session_error(
                where,
                f"the step is logged but {FRAMES_DIR}/{camera} is missing",
                "restore the session folder from a backup",
                SessionIntegrityError,
            )
        return camera, self._log.slots[i][1]

    def _damage(self, i: int, camera: str, problem: FrameProblem) -> FrameDamage:
        chunk = self._frames.chunk_file(camera, problem.slot).relative_to(self._path)
        return FrameDamage(self._path, i, camera, problem.slot, chunk, problem.kind, problem.detail)

    def _damaged(
        self, i: int, camera: str, problem: FrameProblem, action: str
    ) -> FrameDamagedError:
        return self._damage_error(self._damage(i, camera, problem), action)

    def _damage_error(self, damage: FrameDamage, action: str, more: str = "") -> FrameDamagedError:
        """The error that names a damaged frame, and what to do about it."""
        chunk = damage.chunk.as_posix()
        fix = (
            f"nothing is computed from a damaged frame. Restore {self._path / chunk} from a "
            f"backup, or set the frame aside so that the capture takes it again: "
            f"`sassi-bench data verify {self.id} --retake`, then run the capture that made "
            "the session again with the same session id"
        )
        message = session_error(
            f"session {self.id!r} {action} step {damage.step}",
            f"the {damage.camera} frame (slot {damage.slot}, {chunk}) is {damage.kind}: "
            f"{damage.detail}{more}",
            fix,
        )
        return FrameDamagedError(str(message), damage)

    def _warn_problems(self, stacklevel: int) -> None:
        """Warn about the log's problems; ``stacklevel`` counts from this method's caller."""
        for message in self._log.problems:
            warnings.warn(
                f"session {self.id!r}: {message}", SessionWarning, stacklevel=stacklevel + 1
            )
