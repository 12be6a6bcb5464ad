"""One procedure drives a rig at a time, across processes.

Two procedures on one bench would both drive its SLM and cameras (and on the virtual
bench both publish into one data root). Every workflow that drives a rig holds the rig's
lock for its whole run (:func:`drives_rig`), and the command line takes it before a
command's start-up work (``sassi_bench.commands``); a second one, in another process, is
refused with the holder named (pid, host, start time, command). The locks are
:class:`~sassi_bench._shared.lock.WriteLock` files (``flock``: released when the holder
ends or dies):

- ``<data>/locks/<rig>.lock``, for every rig: one procedure per rig and data root;
- for a rig that drives hardware, also machine-wide, whatever the data root (two users
  with their own data roots share one bench): one lock for the rig's name and one for
  each device it drives (the trigger's serial port, resolved through its symlinks, the
  SLM's display, each camera), so two rig descriptions naming one device exclude each
  other. They live in :func:`machine_lock_dir`, one folder per machine.

The virtual bench drives no device: its rigs keep the per-data-root lock only, so two
simulated calibrations with their own data roots may run at once.

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
import hashlib
import inspect
import os
import re
import tempfile
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, TypeVar

from sassi_bench._shared.lock import LockHeldError, WriteLock
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.paths import data_root
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.rig import Rig

__all__ = [
    "LOCKS_DIR",
    "LOCK_DIR_ENV",
    "RigBusyError",
    "device_identities",
    "drives_rig",
    "driving",
    "held_rigs",
    "machine_lock_dir",
    "rig_lock_files",
]

#: Folder of the data root that holds the rig locks.
LOCKS_DIR = "locks"
#: Machine-wide folder of hardware rigs' and devices' locks.
MACHINE_LOCKS = "sassi-bench-rig-locks"
#: Environment variable naming another machine-wide lock folder (one every user of the
#: bench's computer can write; tests use their own).
LOCK_DIR_ENV = "SASSI_BENCH_LOCK_DIR"

F = TypeVar("F", bound=Callable[..., Any])

_held: dict[str, tuple[int, list[WriteLock]]] = {}
_guard = threading.Lock()


class RigBusyError(ProcedureError):
    """Another procedure drives the rig. ``holder`` names it (pid, host, command)."""

    def __init__(self, message: str, holder: str) -> None:
        super().__init__(message)
        self.holder = holder


def _description(rig: Rig | RigDescription) -> RigDescription:
    return rig if isinstance(rig, RigDescription) else rig.description


def machine_lock_dir() -> Path:
    """The machine-wide folder of hardware locks: ``$SASSI_BENCH_LOCK_DIR`` when set, else
    ``/tmp/sassi-bench-rig-locks`` (``/tmp`` itself, not ``$TMPDIR``, which may differ
    between the users of one machine).

    Examples
    --------
    >>> machine_lock_dir().name
    'sassi-bench-rig-locks'
    """
    if os.environ.get(LOCK_DIR_ENV):
        return Path(os.environ[LOCK_DIR_ENV])
    base = Path("/tmp") if os.name == "posix" else Path(tempfile.gettempdir())
    return base / MACHINE_LOCKS


def device_identities(rig: Rig | RigDescription) -> list[tuple[str, str]]:
    """The devices a hardware rig drives, as (what, identity) pairs; none for the
    virtual bench. Two rigs whose devices share an identity drive the same device.

    Examples
    --------
    >>> from sassi_bench.rig import load_rig_description
    >>> [what for what, _ in device_identities(load_rig_description("lab-example"))]
    ['trigger', 'SLM', 'spectral camera', 'guide camera']
    >>> device_identities(load_rig_description("sim"))
    []
    """
    desc = _description(rig)
    hardware = desc.hardware or {}
    if desc.backend == "sim" or not hardware:
        return []
    found = []
    trigger = hardware.get("trigger") or {}
    if trigger.get("port"):
        found.append(("trigger", f"serial {os.path.realpath(trigger['port'])}"))
    if "slm" in hardware:
        found.append(("SLM", f"display {hardware['slm'].get('monitor', 'default')}"))
    for key in ("spectral_camera", "guide_camera"):
        camera = hardware.get(key) or {}
        if camera.get("kind") == "dcam":
            identity = f"dcam {camera.get('index', 0)}"
        elif isinstance(camera.get("device"), dict):
            identity = "genicam " + ",".join(
                f"{k}={v}" for k, v in sorted(camera["device"].items())
            )
        else:
            identity = f"genicam {camera.get('cti')} #{camera.get('device', 0)}"
        found.append((key.replace("_", " "), identity))
    return found


def _lock_name(identity: str) -> str:
    """A file name for a device identity (readable, and unique through a short hash)."""
    readable = re.sub(r"[^A-Za-z0-9._-]+", "_", identity).strip("_")[:60]
    return f"device-{readable}-{hashlib.sha256(identity.encode()).hexdigest()[:8]}.lock"


def _lock_plan(
    rig: Rig | RigDescription, data: str | os.PathLike[str] | None
) -> list[tuple[Path, str]]:
    """The lock files of a rig with what each one guards, in the order they are taken."""
    desc = _description(rig)
    name = desc.name
    plan = []
    if desc.backend != "sim":  # first: a refusal there leaves the data root untouched
        machine = machine_lock_dir()
        plan.append((machine / f"{name}.lock", f"rig {name!r}"))
        plan += [
            (machine / _lock_name(identity), f"the {what} of rig {name!r} ({identity})")
            for what, identity in device_identities(desc)
        ]
    return [*plan, (data_root(data) / LOCKS_DIR / f"{name}.lock", f"rig {name!r}")]


def rig_lock_files(
    rig: Rig | RigDescription, data: str | os.PathLike[str] | None = None
) -> list[Path]:
    """The lock files of ``rig``: in the data root, and machine-wide for hardware (the
    rig's name and each device it drives).

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> [p.as_posix() for p in rig_lock_files(open_rig("sim"), "/lab")]
    ['/lab/locks/sim.lock']
    """
    return [file for file, _ in _lock_plan(rig, data)]


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
    rig: Rig | RigDescription, data: str | os.PathLike[str] | None = None, step: str = "rig"
) -> Iterator[None]:
    """Hold ``rig``'s lock for a block (re-entrant within a process).

    Parameters
    ----------
    rig
        The rig the block drives, or its description (to take the lock before the rig is
        opened: opening a hardware rig already talks to its devices).
    data
        The data root of the run.
    step
        Named in the error.

    Raises
    ------
    RigBusyError
        When another process drives the rig.
    """
    name = _description(rig).name
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


def _acquire(
    rig: Rig | RigDescription, data: str | os.PathLike[str] | None, step: str
) -> list[WriteLock]:
    taken: list[WriteLock] = []
    machine = machine_lock_dir()
    for file, what in _lock_plan(rig, data):
        shared = file.parent == machine
        try:
            _make_folder(file.parent, shared=shared)
            lock = WriteLock(file)
            lock.acquire()
        except LockHeldError as exc:
            for held in taken:
                held.release()
            raise RigBusyError(
                step_error(
                    step,
                    f"{what} is driven by another procedure ({exc.holder})",
                    "wait until it ends, or stop it, then run this again (an interrupted "
                    "run resumes); one procedure drives a rig, and a device, at a time",
                ),
                exc.holder,
            ) from None
        if shared:
            with contextlib.suppress(OSError):
                file.chmod(0o666)
        taken.append(lock)
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
