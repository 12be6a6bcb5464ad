"""An exclusive advisory write lock on a file that names its holder.

The lock is :func:`fcntl.flock` on the file (``LOCK_EX | LOCK_NB``): the operating system
releases it when the holder closes the file or dies, so a crashed writer never leaves a
stale lock. The holder writes its pid, host, command and start time into the file, so the
next writer is told who is in the way. On platforms without ``fcntl`` the lock is a no-op.

Examples
--------
>>> import tempfile
>>> file = Path(tempfile.mkdtemp()) / "write.lock"
>>> first, second = WriteLock(file), WriteLock(file)
>>> first.acquire()
>>> try:
...     second.acquire()
... except LockHeldError as exc:
...     exc.holder.startswith("pid ")
True
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
from datetime import UTC, datetime
from pathlib import Path
from typing import IO, Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: no advisory locks
    fcntl = None  # type: ignore[assignment]

from sassi_bench.paths import shared_mode

__all__ = ["LockHeldError", "WriteLock"]


class LockHeldError(Exception):
    """Another process, or another :class:`WriteLock` on the same file, holds the lock.

    Its ``holder`` attribute describes who: pid, host, start time and command.
    """

    def __init__(self, holder: str) -> None:
        super().__init__(holder)
        self.holder = holder


class WriteLock:
    """The exclusive write lock on ``file`` (created with the umask's mode if missing).

    Parameters
    ----------
    file
        The lock file, e.g. ``<session>/write.lock``.
    """

    def __init__(self, file: Path) -> None:
        self._file = Path(file)
        self._open: IO[bytes] | None = None  # the open lock file while this object holds it

    @property
    def held(self) -> bool:
        """Whether this object holds the lock."""
        return self._open is not None

    def acquire(self) -> None:
        """Take the lock, or do nothing if this object holds it already.

        Raises
        ------
        LockHeldError
            If someone else holds it.
        """
        if self._open is not None or fcntl is None:
            return
        fd = os.open(self._file, os.O_RDWR | os.O_CREAT, shared_mode(directory=False))
        lock = os.fdopen(fd, "r+b")
        try:
            fcntl.flock(lock.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            holder = _describe_holder(lock.read())
            lock.close()
            raise LockHeldError(holder) from None
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


def _holder() -> dict[str, Any]:
    """Who takes the lock: written into the lock file for the next writer to read."""
    return {
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "command": " ".join(sys.argv)[:300],
        "since": datetime.now(UTC).isoformat(timespec="seconds").replace("+00:00", "Z"),
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
