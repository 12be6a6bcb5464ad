"""Where sessions live, ``<data_root>/sessions/<session_id>/``, and how a new one is made.

A new session is built in a hidden folder beside its final place (header, empty event log,
empty frame store), then renamed in: a session folder either does not exist or is
complete, and a concurrent creation of the same id cannot clobber it.
"""

from __future__ import annotations

import os
import shutil
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sassi_bench._shared.atomic import atomic_write_bytes, fsync_dir, temporary_sibling
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.session.errors import session_error
from sassi_bench.acquire.session.events import EVENTS_FILE
from sassi_bench.acquire.session.frames import FrameStore
from sassi_bench.acquire.session.header import (
    SESSION_FILE,
    check_session_id,
    default_session_id,
    is_session_id,
    new_header,
    parse_header,
)
from sassi_bench.paths import data_root
from sassi_bench.rig.config import RigDescription

__all__ = ["LOCK_FILE", "create_session_folder", "find_session", "read_header", "session_folder"]

#: The session writer's lock file (see :mod:`sassi_bench._shared.lock`).
LOCK_FILE = "write.lock"


def session_folder(session_id: str, data: str | os.PathLike[str] | None = None) -> Path:
    """The folder of session ``session_id`` under the data root (which need not exist).

    Examples
    --------
    >>> session_folder("s1", "/lab/data").as_posix()
    '/lab/data/sessions/s1'
    """
    check_session_id(session_id)
    return data_root(data) / "sessions" / session_id


def find_session(
    path_or_id: str | os.PathLike[str], data: str | os.PathLike[str] | None = None
) -> Path:
    """The folder of an existing session, given by folder path or by id.

    A bare id names a session under ``<data>/sessions/``, unless only a folder of that
    name in the current directory is a session.

    Raises
    ------
    SessionError
        If no session (no ``session.json``) is there.

    Examples
    --------
    >>> find_session("nonesuch", "/nonexistent")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.acquire.session.errors.SessionError: session open: no session at ...
    """
    given = Path(path_or_id)
    path = given
    if is_session_id(path_or_id):
        by_id = data_root(data) / "sessions" / str(path_or_id)
        if (by_id / SESSION_FILE).is_file() or not (given / SESSION_FILE).is_file():
            path = by_id
    if not (path / SESSION_FILE).is_file():
        raise session_error(
            "session open",
            f"no session at {path} ({SESSION_FILE} not found)",
            "check the id and the data root (--data / SASSI_BENCH_DATA); "
            "`sassi-bench data list` shows the sessions there",
        )
    return path


def read_header(folder: Path) -> tuple[dict[str, Any], bytes]:
    """The checked header of the session in ``folder``, and its file bytes."""
    file = folder / SESSION_FILE
    raw = file.read_bytes()
    return parse_header(raw, file), raw


def create_session_folder(
    rig_description: RigDescription,
    plan: Plan,
    session_id: str | None,
    data: str | os.PathLike[str] | None,
) -> tuple[Path, dict[str, Any], bytes]:
    """Make a new, empty session folder; return it with its header and the header's bytes.

    Parameters
    ----------
    rig_description, plan
        The rig and the plan the session is for.
    session_id
        Its folder name; None for ``<UTC time>-<plan name>``.
    data
        The data root.

    Raises
    ------
    SessionError
        For an invalid id, or if a session with this id exists (it is never overwritten).
    """
    if not isinstance(plan, Plan):
        raise session_error("session create", f"plan is a {type(plan).__name__}", "pass a Plan")
    now = datetime.now(UTC)
    if session_id is None:
        session_id = default_session_id(plan.name, now)
    target = session_folder(session_id, data)
    if target.exists():
        raise session_error(
            "session create",
            f"session {session_id!r} already exists at {target}",
            "resume it (run the same capture with this session id), or pick another session id",
        )
    header, raw = new_header(session_id, rig_description, plan, now)
    target.parent.mkdir(parents=True, exist_ok=True)
    staging = temporary_sibling(target)
    staging.mkdir()
    try:
        atomic_write_bytes(staging / SESSION_FILE, raw, overwrite=False)
        (staging / EVENTS_FILE).touch()
        FrameStore.create(staging, {"session": session_id, "plan_sha256": header["plan_sha256"]})
        try:
            os.rename(staging, target)
        except OSError as exc:
            raise session_error(
                "session create",
                f"session {session_id!r} appeared at {target} while creating it ({exc})",
                "resume it (run the same capture with this session id), or pick another session id",
            ) from exc
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    fsync_dir(target.parent)
    return target, header, raw
