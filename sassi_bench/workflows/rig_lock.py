"""One procedure drives a rig at a time, across processes.

Two procedures on one bench would both drive its SLM and cameras (and on the virtual
bench both publish into one data root). Every workflow that drives a rig holds the rig's
lock for its whole run (:func:`drives_rig`); a second one, in another process, is refused
with the holder named (pid, host, start time, command). The lock is a
:class:`~sassi_bench._shared.lock.WriteLock` (``flock``: released when the holder ends or
dies), in ``<data>/locks/<rig>.lock`` and, for a hardware rig, also in a folder of the
machine's temporary directory (two users with their own data roots share one bench).

Within one process the lock is re-entrant: the full chain holds it and its stages run
inside.

Examples
--------
>>> import tempfile
>>> from sassi_bench import open_rig
>>> rig, data = open_rig("sim"), tempfile.mkdtemp()
>>> with driving(rig, data, "demo"):
...     with driving(rig, data, "inner stage"):  # the same process: re-entrant
...         held_rigs()
('sim',)
>>> held_rigs()
()
"""

from __future__ import annotations

import contextlib
import functools
import inspect
import os
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

from sassi_bench._shared.lock import LockHeldError, WriteLock
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.paths import data_root
from sassi_bench.rig.rig import Rig

__all__ = ["LOCKS_DIR", "RigBusyError", "drives_rig", "driving", "held_rigs", "rig_lock_files"]

#: Folder of the data root that holds the rig locks.
LOCKS_DIR = "locks"
#: Machine-wide folder of hardware rigs' locks, in the temporary directory.
MACHINE_LOCKS = "sassi-bench-rig-locks"

F = TypeVar("F", bound=Callable[..., Any])

_held: dict[str, tuple[int, list[WriteLock]]] = {}
_guard = threading.Lock()


class RigBusyError(ProcedureError):
    """Another procedure drives the rig. ``holder`` names it (pid, host, command)."""

    def __init__(self, message: str, holder: str) -> None:
        super().__init__(message)
        self.holder = holder


def rig_lock_files(rig: Rig, data: str | os.PathLike[str] | None = None) -> list[Path]:
    """The lock files of ``rig``: in the data root, and machine-wide for hardware.

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> [p.as_posix() for p in rig_lock_files(open_rig("sim"), "/lab")]
    ['/lab/locks/sim.lock']
    """
    name = rig.description.name
    files = [data_root(data) / LOCKS_DIR / f"{name}.lock"]
    if rig.description.backend != "sim":
        files.append(Path(tempfile.gettempdir()) / MACHINE_LOCKS / f"{name}.lock")
    return files


def _make_folder(folder: Path, shared: bool) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    if shared:  # every user of the machine takes hardware locks there
        with contextlib.suppress(OSError):
            folder.chmod(0o1777)


def held_rigs() -> tuple[str, ...]:
    """Names of the rigs this process drives now."""
    with _guard:
        return tuple(sorted(_held))


@contextlib.contextmanager
def driving(
    rig: Rig, data: str | os.PathLike[str] | None = None, step: str = "rig"
) -> Iterator[None]:
    """Hold ``rig``'s lock for a block (re-entrant within a process).

    Parameters
    ----------
    rig
        The rig the block drives.
    data
        The data root of the run.
    step
        Named in the error.

    Raises
    ------
    RigBusyError
        When another process drives the rig.
    """
    name = rig.description.name
    with _guard:
        if name in _held:
            count, locks = _held[name]
            _held[name] = (count + 1, locks)
            acquired = None
        else:
            acquired = _acquire(rig, data, step)
            _held[name] = (1, acquired)
    try:
        yield
    finally:
        with _guard:
            count, locks = _held[name]
            if count > 1:
                _held[name] = (count - 1, locks)
            else:
                del _held[name]
                for lock in reversed(locks):
                    lock.release()


def _acquire(rig: Rig, data: str | os.PathLike[str] | None, step: str) -> list[WriteLock]:
    taken: list[WriteLock] = []
    files = rig_lock_files(rig, data)
    try:
        for index, file in enumerate(files):
            _make_folder(file.parent, shared=index > 0)
            lock = WriteLock(file)
            lock.acquire()
            if index > 0:
                with contextlib.suppress(OSError):
                    file.chmod(0o666)
            taken.append(lock)
    except LockHeldError as exc:
        for lock in taken:
            lock.release()
        raise RigBusyError(
            step_error(
                step,
                f"rig {rig.description.name!r} is driven by another procedure ({exc.holder})",
                "wait until it ends, or stop it, then run this again (an interrupted run "
                "resumes); one procedure drives a rig at a time",
            ),
            exc.holder,
        ) from None
    return taken


def drives_rig(step: str) -> Callable[[F], F]:
    """Decorate a workflow whose first argument is the rig and which takes ``data=``: it
    holds the rig's lock (:func:`driving`) for its whole run.

    Examples
    --------
    >>> import tempfile
    >>> from sassi_bench import open_rig
    >>> @drives_rig("demo capture")
    ... def capture(rig, *, data=None):
    ...     return held_rigs()
    >>> capture(open_rig("sim"), data=tempfile.mkdtemp())
    ('sim',)
    """

    def decorate(function: F) -> F:
        signature = inspect.signature(function)

        @functools.wraps(function)
        def run(*args: Any, **kwargs: Any) -> Any:
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            rig = next(iter(bound.arguments.values()))
            with driving(rig, bound.arguments.get("data"), step):
                return function(*args, **kwargs)

        return run  # type: ignore[return-value]

    return decorate
