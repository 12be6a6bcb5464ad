"""Raw capture sessions on disk: Zarr v3 frames plus an append-only JSON event log.

Layout of ``<data_root>/sessions/<session_id>/``::

    session.json     written once: schema, id, created (UTC), rig description and plan
                     (each with its SHA-256), software version
    frames.zarr/     Zarr v3 group; one array per camera the plan uses, one chunk per
                     frame: ``spectral`` (n, H, W), ``guide`` (n, H, W, 3); a step's slot
                     is its rank among the plan's steps for that camera
    events.jsonl     one JSON line per stored frame, appended and fsync'd after its
                     chunk, so an event exists only for a fully written frame
    events.torn      (only after a crash) bytes of a torn last event line, kept aside
    write.lock       advisory lock of the session's writer (``fcntl.flock``), holding
                     its pid, host, command and start time

A camera's array is created when its first frame is written, with that frame's shape
and dtype; later frames must match. A step is *completed* when its event is in the log.
A torn last line (a crash while appending) is ignored, reported as a
:class:`SessionWarning`, and moved to ``events.torn`` before the next append; its step
is simply captured again. Completed steps are never overwritten. Metadata is JSON only.

One writer at a time: :meth:`Session.writing` (which
:func:`~sassi_bench.acquire.runner.run_plan` holds for a whole run) and every
:meth:`Session.write_frame` take an exclusive advisory lock on ``write.lock``, released at
the end of the block (or by :meth:`Session.close`) and by the operating system when the
process dies. A second writer, in another
process or through another ``Session`` object, gets :class:`SessionLockedError` naming the
holder. Reading never locks.

Examples
--------
>>> import tempfile
>>> tmp = tempfile.TemporaryDirectory()
>>> from sassi_bench.acquire.plan import Plan, Step
>>> from sassi_bench.rig import FrameMeta, Frame, load_rig_description
>>> plan = Plan("demo", [Step("spectral", "led", 0.01, {"kind": "full"})] * 2)
>>> session = Session.create(load_rig_description("sim"), plan, session_id="demo",
...                          data=tmp.name)
>>> frame = Frame(np.full((4, 6), 7, np.uint16), FrameMeta("spectral", 0.01, 0.0, 0, "led", 0))
>>> session.write_frame(1, frame)
>>> session.completed, session.missing, session.read_frame(1)[0, :3].tolist()
(frozenset({1}), (0,), [7, 7, 7])
>>> tmp.cleanup()
"""

from __future__ import annotations

import contextlib
import copy
import hashlib
import json
import os
import re
import shutil
import socket
import sys
import uuid
import warnings
from collections.abc import Callable, Iterable, Iterator
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from numpy.typing import NDArray
from zarr.codecs import ZstdCodec
from zarr.storage import LocalStore

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: no advisory locks
    fcntl = None  # type: ignore[assignment]

from sassi_bench.acquire.plan import Plan, PlanError, canonical_json, to_json_value
from sassi_bench.errors import SassiBenchError, step_error
from sassi_bench.paths import data_root, shared_mode
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.frame import Frame

__all__ = [
    "SCHEMA_NAME",
    "SCHEMA_VERSION",
    "Session",
    "SessionError",
    "SessionIntegrityError",
    "SessionLockedError",
    "SessionWarning",
    "check_session_id",
    "frame_sha256",
]

SCHEMA_NAME = "sassi-bench/session"
SCHEMA_VERSION = "1.0"
SESSION_FILE = "session.json"
FRAMES_DIR = "frames.zarr"
EVENTS_FILE = "events.jsonl"
TORN_FILE = "events.torn"
LOCK_FILE = "write.lock"

_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,199}$")
_INFO_KEYS = ("schema", "version", "id", "created", "rig", "rig_sha256", "plan", "plan_sha256")
_EVENT_KEYS = ("step", "camera", "slot", "meta", "pattern", "tags", "sha256", "dtype", "shape")


class SessionError(SassiBenchError, ValueError):
    """A session cannot be created, opened or written as asked."""


class SessionIntegrityError(SessionError):
    """Stored frames or session files no longer match what was recorded."""


class SessionLockedError(SessionError):
    """Another process (or Session object) is writing the session."""


class SessionWarning(UserWarning):
    """Something recoverable was found in a session (e.g. a torn last event line)."""


def frame_sha256(data: NDArray[Any]) -> str:
    """SHA-256 (hex) of a frame's pixel bytes: C order, little-endian.

    Examples
    --------
    >>> frame_sha256(np.zeros((1, 1), np.uint16))[:12]
    '96a296d224f2'
    """
    arr = np.asarray(data)
    little = arr.astype(arr.dtype.newbyteorder("<"), copy=False)
    return hashlib.sha256(np.ascontiguousarray(little).tobytes()).hexdigest()


def _utc_now() -> datetime:
    return datetime.now(UTC)


def _error(step: str, cause: str, fix: str, kind: type[SessionError] = SessionError):
    return kind(step_error(step, cause, fix))


def _fsync_path(path: Path) -> None:
    # Directories too: a rename or new file is durable only once its directory is synced.
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover - some filesystems refuse fsync on directories
        pass
    finally:
        os.close(fd)


def _temp_name(path: Path) -> Path:
    # Not tempfile.mkstemp/mkdtemp: those ignore the umask (0600/0700), and sessions are
    # often shared by a lab group.
    return path.with_name(f".{path.name}.{uuid.uuid4().hex[:12]}.tmp")


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = _temp_name(path)
    try:
        with open(tmp, "xb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _fsync_path(path.parent)


def _software_version() -> str:
    from sassi_bench import __version__

    return __version__


def _camera_slots(plan: Plan) -> tuple[dict[str, list[int]], list[int]]:
    """Per camera, the plan step of each array slot; per step, its slot."""
    steps: dict[str, list[int]] = {camera: [] for camera in plan.cameras}
    slot_of = []
    for i, step in enumerate(plan.steps):
        slot_of.append(len(steps[step.camera]))
        steps[step.camera].append(i)
    return steps, slot_of


class Session:
    """A raw capture session on disk (see the module docstring for the layout).

    Use :meth:`create`, :meth:`open` or :meth:`open_or_create`; the constructor is
    private.
    """

    def __init__(self, path: Path, info: dict[str, Any], info_bytes: bytes) -> None:
        self._path = path
        self._info = info
        self._info_bytes = info_bytes
        self._plan = Plan.from_dict(info["plan"])
        self._slot_steps, self._slot_of = _camera_slots(self._plan)
        self._store = LocalStore(path / FRAMES_DIR)
        self._group = zarr.open_group(store=self._store, mode="r+")
        self._arrays: dict[str, zarr.Array] = {}
        # step -> (raw line bytes incl. newline, parsed event)
        self._events: dict[int, tuple[bytes, dict[str, Any]]] = {}
        self._log_order: list[int] = []
        self._good_size = 0
        self._torn: bytes = b""
        self._problems: list[str] = []
        self._lock: Any = None  # the open write.lock while this object holds it
        self._load_events()

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
        if not isinstance(plan, Plan):
            raise _error("session create", f"plan is a {type(plan).__name__}", "pass a Plan")
        now = _utc_now()
        if session_id is None:
            safe_name = re.sub(r"[^A-Za-z0-9._-]+", "-", plan.name).strip("-.") or "plan"
            session_id = f"{now:%Y%m%dT%H%M%SZ}-{safe_name}"[:200]
        _check_id(session_id)
        sessions = data_root(data) / "sessions"
        target = sessions / session_id
        if target.exists():
            raise _error(
                "session create",
                f"session {session_id!r} already exists at {target}",
                "resume it with Session.open (or Session.open_or_create), "
                "or pick another session_id",
            )
        rig = rig_description.to_dict()
        info = {
            "schema": SCHEMA_NAME,
            "version": SCHEMA_VERSION,
            "id": session_id,
            "created": now.isoformat(timespec="milliseconds").replace("+00:00", "Z"),
            "rig": rig,
            "rig_sha256": rig_description.sha256(),
            "plan": plan.to_dict(),
            "plan_sha256": plan.sha256(),
            "software": {"sassi_bench": _software_version()},
        }
        info_bytes = (json.dumps(info, indent=2, sort_keys=True) + "\n").encode("utf-8")

        # Build the session beside its final place, then rename it in: a session folder
        # either does not exist or is complete, and a concurrent create cannot clobber it.
        sessions.mkdir(parents=True, exist_ok=True)
        staging = _temp_name(target)
        staging.mkdir()
        try:
            _write_atomic(staging / SESSION_FILE, info_bytes)
            (staging / EVENTS_FILE).touch()
            zarr.create_group(
                store=LocalStore(staging / FRAMES_DIR),
                attributes={"session": session_id, "plan_sha256": info["plan_sha256"]},
            )
            try:
                os.rename(staging, target)
            except OSError as exc:
                raise _error(
                    "session create",
                    f"session {session_id!r} appeared at {target} while creating it ({exc})",
                    "resume it with Session.open, or pick another session_id",
                ) from exc
        except BaseException:
            shutil.rmtree(staging, ignore_errors=True)
            raise
        _fsync_path(sessions)
        return cls(target, info, info_bytes)

    @classmethod
    def open(
        cls, path_or_id: str | os.PathLike[str], *, data: str | os.PathLike[str] | None = None
    ) -> Session:
        """Open an existing session by folder path or by id under ``<data>/sessions/``.

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
        given = Path(path_or_id)
        path = given
        if isinstance(path_or_id, str) and _ID_RE.match(path_or_id):
            # A bare id names a session under the data root, unless only a folder of
            # that name in the current directory is a session.
            by_id = data_root(data) / "sessions" / path_or_id
            if (by_id / SESSION_FILE).is_file() or not (given / SESSION_FILE).is_file():
                path = by_id
        file = path / SESSION_FILE
        if not file.is_file():
            raise _error(
                "session open",
                f"no session at {path} ({SESSION_FILE} not found)",
                "check the id and the data root (--data / SASSI_BENCH_DATA), "
                "or create it with Session.create",
            )
        info_bytes = file.read_bytes()
        info = _parse_info(info_bytes, file)
        return cls(path, info, info_bytes)

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
        _check_id(session_id)
        path = data_root(data) / "sessions" / session_id
        if not path.exists():
            return cls.create(rig_description, plan, session_id=session_id, data=data)
        session = cls.open(path)
        if session.plan_sha256 != plan.sha256():
            raise _error(
                "session resume",
                f"session {session_id!r} was created for plan {session.plan.name!r} "
                f"(sha256 {session.plan_sha256[:12]}), not for plan {plan.name!r} "
                f"(sha256 {plan.sha256()[:12]})",
                "pick another session_id for the new plan, or resume the stored plan "
                "(Session.open(id).plan)",
            )
        if session.rig_sha256 != rig_description.sha256():
            raise _error(
                "session resume",
                f"session {session_id!r} was captured on rig {session.rig.get('name')!r} "
                f"(sha256 {session.rig_sha256[:12]}), which differs from rig "
                f"{rig_description.name!r} (sha256 {rig_description.sha256()[:12]})",
                "open the rig described in the session's session.json, or pick another session_id",
            )
        return session

    # -- properties -------------------------------------------------------------------
    @property
    def id(self) -> str:
        """The session id (its folder name)."""
        return str(self._info["id"])

    @property
    def path(self) -> Path:
        """The session folder."""
        return self._path

    @property
    def created(self) -> str:
        """Creation time, UTC ISO 8601."""
        return str(self._info["created"])

    @property
    def plan(self) -> Plan:
        """The plan the session captures."""
        return self._plan

    @property
    def plan_sha256(self) -> str:
        """SHA-256 of the plan (:meth:`Plan.sha256`)."""
        return str(self._info["plan_sha256"])

    @property
    def rig(self) -> dict[str, Any]:
        """The rig description (a copy of ``RigDescription.to_dict()``)."""
        return copy.deepcopy(self._info["rig"])

    @property
    def rig_sha256(self) -> str:
        """SHA-256 of the rig description (:meth:`RigDescription.sha256`)."""
        return str(self._info["rig_sha256"])

    @property
    def problems(self) -> tuple[str, ...]:
        """Recoverable problems found when the session was opened (also warned about)."""
        return tuple(self._problems)

    @property
    def completed(self) -> frozenset[int]:
        """Indices of the steps whose frames are stored."""
        return frozenset(self._events)

    @property
    def missing(self) -> tuple[int, ...]:
        """Indices of the steps still to capture, in plan order."""
        return tuple(i for i in range(len(self._plan)) if i not in self._events)

    @property
    def is_complete(self) -> bool:
        """Whether every step of the plan is stored."""
        return len(self._events) == len(self._plan)

    def __repr__(self) -> str:
        return (
            f"Session({self.id!r}, plan={self._plan.name!r}, "
            f"{len(self._events)}/{len(self._plan)} frames, path={str(self._path)!r})"
        )

    # -- writing ----------------------------------------------------------------------
    @property
    def locked_for_writing(self) -> bool:
        """Whether this object holds the session's write lock."""
        return self._lock is not None

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
        if self._lock is not None or fcntl is None:
            return
        fd = os.open(self._path / LOCK_FILE, os.O_RDWR | os.O_CREAT, shared_mode(directory=False))
        lock = os.fdopen(fd, "r+b")
        try:
            fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = _describe_holder(lock.read())
            lock.close()
            raise _error(
                f"session {self.id!r} write",
                f"another writer holds the session ({holder})",
                "let it finish or stop it, then resume; one process at a time may capture "
                "into a session (reading it is always fine)",
                SessionLockedError,
            ) from None
        lock.seek(0)
        lock.truncate()
        lock.write(json.dumps(_holder()).encode("utf-8"))
        lock.flush()
        self._lock = lock
        if (self._path / EVENTS_FILE).stat().st_size != self._good_size + len(self._torn):
            self._reload_events()

    def close(self) -> None:
        """Release the write lock, if this object holds it (reading stays possible)."""
        lock, self._lock = self._lock, None
        if lock is not None:
            with contextlib.suppress(OSError):
                lock.truncate(0)
            lock.close()  # closing the file releases the lock

    @contextlib.contextmanager
    def writing(self) -> Iterator[Session]:
        """Hold the write lock for a block (released at its end unless held before).

        Examples
        --------
        >>> with session.writing():  # doctest: +SKIP
        ...     session.write_frame(0, frame)
        """
        held = self._lock is not None
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

    def _reload_events(self) -> None:
        self._events, self._log_order = {}, []
        self._good_size, self._torn, self._problems = 0, b"", []
        self._load_events()

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
        See the module docstring.
        """
        with self.writing():
            self._write_frame(step_index, frame)

    def _write_frame(self, step_index: int, frame: Frame) -> None:
        i = self._check_index(step_index)
        step = self._plan.steps[i]
        where = f"session {self.id!r} write step {i}"
        if i in self._events:
            raise _error(
                where,
                "this step is already stored (completed steps are never overwritten)",
                "capture into a new session (Session.create with another id) to retake it",
            )
        if not isinstance(frame, Frame):
            raise _error(where, f"got a {type(frame).__name__}", "pass a Frame from a camera")
        data = np.asarray(frame.data)
        _check_frame_camera(where, step.camera, frame.meta.camera, data)
        try:
            meta = to_json_value(frame.meta.to_dict(), "frame.meta")
        except PlanError as exc:
            raise _error(
                where,
                f"the frame metadata is not JSON ({exc})",
                "make the camera adapter put JSON values (str, numbers, lists, dicts) in "
                "FrameMeta.extra",
            ) from exc
        arr = self._array_for(step.camera, data, where)
        slot = self._slot_of[i]
        arr[slot] = data
        self._sync_chunk(arr, slot)
        step_dict = step.to_dict()
        event = {
            "step": i,
            "camera": step.camera,
            "slot": slot,
            "meta": meta,
            "pattern": step_dict["pattern"],
            "tags": step_dict["tags"],
            "sha256": frame_sha256(data),
            "dtype": data.dtype.str,
            "shape": list(data.shape),
            "written": _utc_now().isoformat(timespec="milliseconds").replace("+00:00", "Z"),
        }
        line = (canonical_json(event) + "\n").encode("ascii")
        self._append_event(line)
        self._events[i] = (line, event)
        self._log_order.append(i)

    def _array_for(self, camera: str, data: NDArray[Any], where: str) -> zarr.Array:
        shape = (len(self._slot_steps[camera]), *data.shape)
        arr = self._array(camera)
        if arr is not None and (arr.shape == shape and arr.dtype == data.dtype):
            return arr
        if arr is not None and any(self._plan.steps[i].camera == camera for i in self._events):
            raise _error(
                where,
                f"frame is {data.dtype} {data.shape}, but the {camera} frames stored "
                f"so far are {arr.dtype} {arr.shape[1:]}",
                "keep the camera's resolution, binning and pixel format fixed for the "
                "whole session, or start a new session",
            )
        # New array, or one left by a crash before its first event: nothing is lost.
        arr = self._group.create_array(
            camera,
            shape=shape,
            chunks=(1, *data.shape),
            dtype=data.dtype,
            fill_value=0,
            compressors=ZstdCodec(level=3),
            attributes={"camera": camera, "steps": self._slot_steps[camera]},
            config={"write_empty_chunks": True},
            overwrite=True,
        )
        # Its folders are synced with the first chunk (see _sync_chunk).
        _fsync_path(self._path / FRAMES_DIR / camera / "zarr.json")
        self._arrays[camera] = arr
        return arr

    def _array(self, camera: str) -> zarr.Array | None:
        if camera not in self._arrays:
            if not (self._path / FRAMES_DIR / camera / "zarr.json").is_file():
                return None
            self._arrays[camera] = zarr.open_array(
                store=self._store, path=camera, mode="r+", config={"write_empty_chunks": True}
            )
        return self._arrays[camera]

    def _chunk_file(self, arr: zarr.Array, slot: int) -> Path:
        key = arr.metadata.encode_chunk_key((slot,) + (0,) * (arr.ndim - 1))
        return self._path / FRAMES_DIR / arr.path / key

    def _sync_chunk(self, arr: zarr.Array, slot: int) -> None:
        # Zarr writes chunks atomically (temp + rename) but does not fsync them.
        chunk = self._chunk_file(arr, slot)
        _fsync_path(chunk)
        root = self._path / FRAMES_DIR
        for folder in chunk.parents:
            _fsync_path(folder)
            if folder == root:
                break

    def _append_event(self, line: bytes) -> None:
        events = self._path / EVENTS_FILE
        if events.stat().st_size != self._good_size:
            with open(events, "rb") as f:
                f.seek(self._good_size)
                torn = f.read()
            if torn != self._torn:
                raise _error(
                    f"session {self.id!r} write",
                    f"{EVENTS_FILE} changed since the session was opened (another writer?)",
                    "write a session from one process only; reopen it with Session.open",
                )
            # Keep the torn bytes aside (nothing is ever thrown away), then cut them off
            # so the new line starts on a line of its own.
            with open(self._path / TORN_FILE, "ab") as f:
                f.write(torn + b"\n")
                f.flush()
                os.fsync(f.fileno())
            os.truncate(events, self._good_size)
            self._torn = b""
        with open(events, "ab") as f:
            f.write(line)
            f.flush()
            os.fsync(f.fileno())
        self._good_size += len(line)

    # -- reading ----------------------------------------------------------------------
    def read_frame(self, step_index: int) -> NDArray[Any]:
        """The stored frame of step ``step_index`` (a read-only array).

        Examples
        --------
        See the module docstring.
        """
        i = self._check_index(step_index)
        arr, slot = self._locate(i, "read")
        out = np.asarray(arr[slot])
        out.setflags(write=False)
        return out

    def read_frames(self, step_indices: Iterable[int]) -> NDArray[Any]:
        """Frames of several steps of one camera, stacked along a new first axis.

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
            raise _error("session read", "no step indices given", "pass at least one index")
        located = [self._locate(i, "read") for i in indices]
        cameras = {self._plan.steps[i].camera for i in indices}
        if len(cameras) > 1:
            raise _error(
                f"session {self.id!r} read",
                f"steps {indices} mix cameras {sorted(cameras)}",
                "read each camera's steps separately (plan.select / step.camera)",
            )
        arr = located[0][0]
        out = np.asarray(arr.oindex[np.array([slot for _, slot in located])])
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
        return [copy.deepcopy(self._events[i][1]) for i in self._log_order]

    def event(self, step_index: int) -> dict[str, Any]:
        """The event of one stored step (a copy)."""
        i = self._check_index(step_index)
        self._locate(i, "read")
        return copy.deepcopy(self._events[i][1])

    # -- identity and integrity -------------------------------------------------------
    def sha256(self) -> str:
        """SHA-256 over ``session.json`` and the completed steps' event lines in step order.

        Each event carries its frame's hash, so this identifies the session's content
        (for a bundle's ``inputs``). It changes when frames are added.
        """
        h = hashlib.sha256(self._info_bytes)
        for i in sorted(self._events):
            h.update(self._events[i][0])
        return h.hexdigest()

    def verify(self) -> int:
        """Re-hash every stored frame against its event.

        Returns
        -------
        int
            Number of frames verified.

        Raises
        ------
        SessionIntegrityError
            Naming the first step whose stored data changed or cannot be read.
        """
        for i in sorted(self._events):
            event = self._events[i][1]
            arr, slot = self._locate(i, "verify")
            chunk = self._chunk_file(arr, slot)
            fix = (
                "recapture this step into a new session, or restore "
                f"{chunk.relative_to(self._path)} from a backup"
            )
            try:
                data = np.asarray(arr[slot])
            except Exception as exc:
                raise _error(
                    f"session {self.id!r} verify step {i}",
                    f"the {event['camera']} frame (slot {slot}) cannot be read ({exc})",
                    fix,
                    SessionIntegrityError,
                ) from exc
            if frame_sha256(data) != event["sha256"] or list(data.shape) != event["shape"]:
                raise _error(
                    f"session {self.id!r} verify step {i}",
                    f"the stored {event['camera']} frame (slot {slot}) changed since capture "
                    f"(sha256 {frame_sha256(data)[:12]}, recorded {event['sha256'][:12]})",
                    fix,
                    SessionIntegrityError,
                )
        return len(self._events)

    # -- internals --------------------------------------------------------------------
    def _check_index(self, step_index: int) -> int:
        n = len(self._plan)
        if isinstance(step_index, bool) or not isinstance(step_index, (int, np.integer)):
            raise _error(
                f"session {self.id!r}",
                f"step index {step_index!r} is not an integer",
                "pass a step index (see plan.select)",
            )
        if not 0 <= step_index < n:
            raise _error(
                f"session {self.id!r}",
                f"step index {step_index} is out of range (the plan has {n} steps)",
                f"use 0..{n - 1}",
            )
        return int(step_index)

    def _locate(self, i: int, action: str) -> tuple[zarr.Array, int]:
        camera = self._plan.steps[i].camera
        where = f"session {self.id!r} {action} step {i}"
        if i not in self._events:
            raise _error(
                where,
                "this step was never captured",
                "run the plan to capture it (run_plan resumes where it stopped); "
                "session.missing lists what is left",
            )
        arr = self._array(camera)
        if arr is None:
            raise _error(
                where,
                f"the step is logged but {FRAMES_DIR}/{camera} is missing",
                "restore the session folder from a backup",
                SessionIntegrityError,
            )
        return arr, self._slot_of[i]

    def _load_events(self) -> None:
        raw = (self._path / EVENTS_FILE).read_bytes()
        lines = raw.split(b"\n")
        # A complete log ends with a newline, leaving an empty last piece.
        tail = lines.pop()
        offset = 0
        parsed: list[tuple[bytes, dict[str, Any] | None, str]] = []
        for body in lines:
            line = body + b"\n"
            event, reason = self._parse_event(body)
            parsed.append((line, event, reason))
        if tail:
            parsed.append((tail, None, "it has no line end"))
        for k, (line, event, reason) in enumerate(parsed):
            last = k == len(parsed) - 1
            if event is None:
                if not last:
                    raise _error(
                        f"session {self.id!r} open",
                        f"{EVENTS_FILE} line {k + 1} is damaged ({reason})",
                        "restore the session from a backup; only a torn last line is "
                        "repaired automatically",
                        SessionIntegrityError,
                    )
                self._torn = line
                self._report(
                    f"{EVENTS_FILE}: ignored a torn last line ({reason}; {len(line)} bytes), "
                    "left by an interrupted write; its step will be captured again"
                )
                break
            i = event["step"]
            if i in self._events:
                self._report(
                    f"{EVENTS_FILE}: step {i} is logged twice; the later event is used "
                    "(run verify() to check the data)"
                )
                self._log_order.remove(i)
            self._events[i] = (line, event)
            self._log_order.append(i)
            offset += len(line)
        self._good_size = offset

    def _parse_event(self, body: bytes) -> tuple[dict[str, Any] | None, str]:
        try:
            event = json.loads(body.decode("utf-8"))
        except (UnicodeDecodeError, ValueError) as exc:
            return None, f"not JSON: {exc}"
        if not isinstance(event, dict) or any(key not in event for key in _EVENT_KEYS):
            return None, "missing event keys"
        i = event["step"]
        if not isinstance(i, int) or not 0 <= i < len(self._plan):
            return None, f"step {i!r} is not a step of the plan"
        if event["camera"] != self._plan.steps[i].camera or event["slot"] != self._slot_of[i]:
            return None, f"step {i}'s camera or slot disagrees with the plan"
        return event, ""

    def _report(self, message: str) -> None:
        self._problems.append(message)
        warnings.warn(f"session {self.id!r}: {message}", SessionWarning, stacklevel=4)


def _holder() -> dict[str, Any]:
    """Who takes a write lock: written into ``write.lock`` for the next writer to read."""
    return {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "command": " ".join(sys.argv)[:300],
        "since": _utc_now().isoformat(timespec="seconds").replace("+00:00", "Z"),
    }


def _describe_holder(raw: bytes) -> str:
    try:
        info = json.loads(raw.decode("utf-8"))
        return (
            f"pid {int(info['pid'])} on {info['host']}, since {info['since']}: "
            f"{info['command'] or 'python'}"
        )
    except (ValueError, KeyError, TypeError, UnicodeDecodeError):
        return "a process that has not yet written its pid"


def _check_id(session_id: str) -> None:
    if not isinstance(session_id, str) or not _ID_RE.match(session_id):
        raise _error(
            "session id",
            f"{session_id!r} is not a valid session id",
            "use 1-200 letters, digits, '.', '_' or '-', starting with a letter or digit",
        )


def check_session_id(session_id: str) -> None:
    """Refuse a session id that is not a plain folder name (before anything is captured).

    Examples
    --------
    >>> check_session_id("lab-2026-11-22")
    """
    _check_id(session_id)


def _check_frame_camera(where: str, camera: str, frame_camera: str, data: NDArray[Any]) -> None:
    # Adapters may name cameras by device id; only the two canonical names are checked.
    if frame_camera in ("spectral", "guide") and frame_camera != camera:
        raise _error(
            where,
            f"the step is for the {camera} camera but the frame came from {frame_camera}",
            f"capture with rig.{camera}_camera",
        )
    rgb = data.ndim == 3 and data.shape[-1] == 3
    if (camera == "spectral" and data.ndim != 2) or (camera == "guide" and not rgb):
        expected = "(H, W)" if camera == "spectral" else "(H, W, 3)"
        raise _error(
            where,
            f"a {camera} frame must have shape {expected}, got {data.shape}",
            f"capture with rig.{camera}_camera",
        )
    if data.dtype.kind not in "biuf":
        raise _error(where, f"frame dtype {data.dtype} is not numeric", "pass camera pixels")


def _parse_info(info_bytes: bytes, file: Path) -> dict[str, Any]:
    fix = "restore the session folder from a backup"
    try:
        info = json.loads(info_bytes.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise _error("session open", f"{file} is not JSON ({exc})", fix) from exc
    if not isinstance(info, dict) or info.get("schema") != SCHEMA_NAME:
        raise _error("session open", f"{file} is not a {SCHEMA_NAME} file", fix)
    missing = [key for key in _INFO_KEYS if key not in info]
    if missing:
        raise _error("session open", f"{file} lacks {', '.join(missing)}", fix)
    major = str(info["version"]).split(".")[0]
    if major != SCHEMA_VERSION.split(".")[0]:
        raise _error(
            "session open",
            f"{file} has schema version {info['version']}, this software reads "
            f"{SCHEMA_VERSION.split('.')[0]}.x",
            "upgrade sassi_bench",
        )
    plan = Plan.from_dict(info["plan"])
    rig_sha = hashlib.sha256(canonical_json(info["rig"]).encode("ascii")).hexdigest()
    if plan.sha256() != info["plan_sha256"] or rig_sha != info["rig_sha256"]:
        raise _error(
            "session open",
            f"{file}: the stored plan or rig does not match its recorded sha256",
            fix,
            SessionIntegrityError,
        )
    return info
