"""An exclusive advisory lock on a file that names its holder.

The lock is :func:`fcntl.flock` on the file (``LOCK_EX``): the operating system releases
it when the holder closes the file or dies, so a crashed holder never leaves a stale
lock. The holder writes its pid, host, command and start time into the file, so the next
one is told who is in the way. On platforms without ``fcntl`` the lock is a no-op.

Examples
--------
>>> import tempfile
>>> file = Path(tempfile.mkdtemp()) / "write.lock"
>>> first, second = WriteLock(file), WriteLock(file)
>>> first.acquire()
>>> try:
...     second.acquire()
... except LockHeldError as exc:
...     exc.holder.startswith("pid "), exc.info["pid"] == os.getpid()
(True, True)
>>> first.release()
>>> second.acquire(); second.held
True
>>> second.release()
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: no advisory locks
    fcntl = None  # type: ignore[assignment]

__all__ = ["LockHeldError", "WriteLock", "describe_holder"]

_POLL_S = 0.05


class LockHeldError(Exception):
    """Another process, or another :class:`WriteLock` on the same file, holds the lock.

    Attributes
    ----------
    holder
        Who holds it, in words: pid, host, start time and command.
    info
        The holder's record as it wrote it (``pid``, ``host``, ``command``, ``since``),
        empty when it has not written it yet.
    """

    def __init__(self, holder: str, info: dict[str, Any] | None = None) -> None:
        super().__init__(holder)
        self.holder = holder
        self.info = dict(info or {})


class WriteLock:
    """The exclusive lock on ``file`` (created with the umask's mode if missing).

    Parameters
    ----------
    file
        The lock file, e.g. ``<session>/write.lock``; its folder must exist.
    """

    def __init__(self, file: str | os.PathLike[str]) -> None:
        self._file = Path(file)
        self._open: IO[bytes] | None = None  # the open lock file while this object holds it

    @property
    def file(self) -> Path:
        """The lock file."""
        return self._file

    @property
    def held(self) -> bool:
        """Whether this object holds the lock."""
        return self._open is not None

    def acquire(self, wait_s: float = 0.0) -> None:
        """Take the lock, or do nothing if this object holds it already.

        Parameters
        ----------
        wait_s
            How long to wait for another holder to let go (0: not at all).

        Raises
        ------
        LockHeldError
            If someone else still holds it after ``wait_s`` seconds.
        """
        if self._open is not None or fcntl is None:
            return
        # os.open applies the umask, so the file gets the mode a shared lab record gets.
        fd = os.open(self._file, os.O_RDWR | os.O_CREAT, 0o666)
        lock = os.fdopen(fd, "r+b")
        deadline = time.monotonic() + max(0.0, wait_s)
        while True:
            try:
                fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except OSError:
                if time.monotonic() >= deadline:
                    info = _read_holder(lock.read())
                    lock.close()
                    raise LockHeldError(describe_holder(info), info) from None
                time.sleep(_POLL_S)
        lock.seek(0)
        lock.truncate()
        lock.write(json.dumps(_holder()).encode("utf-8"))
        lock.flush()
        self._open = lock

    def release(self) -> None:
        """Release the lock, if this object holds it."""
        lock, self._open = self._open, None
        if lock is not None:
            with contextlib.suppress(OSError):
                lock.truncate(0)
            lock.close()  # closing the file releases the lock

    def __enter__(self) -> WriteLock:
        self.acquire()
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def _holder() -> dict[str, Any]:
    """Who takes the lock: written into the lock file for the next one to read."""
    return {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "command": " ".join(sys.argv)[:300],
        "since": datetime.now(UTC).isoformat(timespec="seconds").replace("+00:00", "Z"),
    }


def _read_holder(raw: bytes) -> dict[str, Any]:
    try:
        info = json.loads(raw.decode("utf-8"))
    except (ValueError, UnicodeDecodeError):
        return {}
    return info if isinstance(info, dict) else {}


def describe_holder(info: dict[str, Any]) -> str:
    """A lock holder's record in words.

    Examples
    --------
    >>> describe_holder({"pid": 7, "host": "lab", "since": "2026-01-01T10:00:00Z",
    ...                  "command": "sassi-bench calibrate"})
    'pid 7 on lab, since 2026-01-01T10:00:00Z: sassi-bench calibrate'
    >>> describe_holder({})
    'a process that has not yet written its pid'
    """
    try:
        return (
            f"pid {int(info['pid'])} on {info['host']}, since {info['since']}: "
            f"{info['command'] or 'python'}"
        )
    except (KeyError, TypeError, ValueError):
        return "a process that has not yet written its pid"
