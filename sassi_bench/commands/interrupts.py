"""Stopping a command: Ctrl-C, SIGTERM and SIGHUP end it the same way, with the resume
command printed and recorded.

``timeout``, a batch system and a closed SSH session stop a process with SIGTERM or
SIGHUP, not Ctrl-C. While a command runs, :func:`stop_signals` turns both into
:class:`Stopped`, a :class:`KeyboardInterrupt`, so every layer that keeps its work on
Ctrl-C (the plan runner keeps each stored frame; atomic writes remove their temporary
file) does the same. A command that captures records its run as soon as its session ids
are fixed (:func:`record_start`, in ``<data>/runs/``: what SIGKILL or a power cut cannot
print is there, and ``sassi-bench data list`` shows it); :func:`record_end` removes the
record when the run ends, or marks it interrupted.

Examples
--------
>>> with stop_signals():
...     pass
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType

from sassi_bench.commands.options import resume_command
from sassi_bench.errors import SassiBenchError

__all__ = [
    "Stopped",
    "incomplete_sessions",
    "record_end",
    "record_start",
    "run_session_folders",
    "signal_name",
    "stop_signals",
]

#: Signals that stop a command like Ctrl-C (SIGHUP: the terminal or SSH session closed).
STOP_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)


class Stopped(KeyboardInterrupt):
    """A stop signal other than Ctrl-C arrived; ``signum`` says which."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal_name(signum))
        self.signum = signum


def signal_name(signum: int) -> str:
    """``"SIGTERM"`` for 15.

    Examples
    --------
    >>> signal_name(signal.SIGTERM)
    'SIGTERM'
    """
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


@contextlib.contextmanager
def stop_signals() -> Iterator[None]:
    """Raise :class:`Stopped` on SIGTERM and SIGHUP while the block runs.

    The first signal raises; the handlers then go back to what they were, so a second
    one (``timeout -k``, an impatient operator) ends the process at once: everything
    written is already safe on disk. Outside the main thread (where Python cannot set
    handlers) this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}

    def restore() -> None:
        for signum, handler in previous.items():
            signal.signal(signum, handler)

    def stop(signum: int, frame: object) -> None:
        restore()
        raise Stopped(signum)

    previous_hook = sys.unraisablehook

    def swallowed(unraisable: sys.UnraisableHookArgs) -> None:
        # A handler's exception raised inside a C callback (the JIT compiler's cache
        # callback, say) is printed and dropped there, and the command would run on.
        # Raise it again at the first profile event outside this hook.
        stopped = unraisable.exc_value
        if isinstance(stopped, Stopped):
            sys.setprofile(_raise_outside(sys._getframe(), stopped.signum))
            return
        previous_hook(unraisable)

    for signum in STOP_SIGNALS:
        signal.signal(signum, stop)
    sys.unraisablehook = swallowed
    try:
        yield
    finally:
        restore()
        sys.unraisablehook = previous_hook


def _raise_outside(hook: FrameType, signum: int) -> Callable:
    """A profile function that raises :class:`Stopped` at the first event outside the
    frame ``hook`` (a call, a return or a built-in call in the code that runs next),
    then puts back the profiler that was there before."""
    previous = sys.getprofile()

    def profile(frame: FrameType, event: str, arg: object) -> None:
        if frame is not hook:
            sys.setprofile(previous)
            raise Stopped(signum)

    return profile


def _sessions(args: argparse.Namespace) -> list[str]:
    return [
        str(value)
        for dest, _ in getattr(args, "resume_options", ())
        if (value := getattr(args, dest, None)) is not None
    ]


def record_start(args: argparse.Namespace) -> Path | None:
    """Record a run that is about to capture (``args.argv`` is its command line; set by
    :func:`sassi_bench.commands.main`). Nothing without a command line or session ids."""
    from sassi_bench.storage.runs import record_run

    argv, sessions = getattr(args, "argv", None), _sessions(args)
    if argv is None or not sessions:
        return None
    command = resume_command(argv, args)
    return record_run(getattr(args, "data", None), sessions[0], str(command), sessions)


def record_end(args: argparse.Namespace, interrupted: str | None = None) -> None:
    """The run of ``args`` ended: remove its record, or mark it ``interrupted`` (how).

    A run that ended on an error keeps its record (as interrupted) when one of its
    sessions is left incomplete: it resumes from there.
    """
    from sassi_bench.storage.runs import end_run

    sessions = _sessions(args)
    if getattr(args, "argv", None) is None or not sessions:
        return
    with contextlib.suppress(SassiBenchError, OSError):  # a bad data root was said already
        end_run(getattr(args, "data", None), sessions[0], interrupted)


def run_session_folders(args: argparse.Namespace) -> list[Path]:
    """The session folders on disk of the run of ``args``: its session ids, the sessions
    named after them (``<id>-...``) and a chain's staged sessions."""
    from sassi_bench.paths import data_root

    try:
        root = data_root(getattr(args, "data", None))
    except SassiBenchError:
        return []
    found: list[Path] = []
    for run in _sessions(args):
        for folder in (
            *root.glob(f"sessions/{run}"),
            *root.glob(f"sessions/{run}-*"),
            *root.glob(f"staging/{run}/sessions/*"),
        ):
            if folder not in found:
                found.append(folder)
    return found


def incomplete_sessions(args: argparse.Namespace) -> list[str]:
    """The run's sessions on disk with fewer frames stored than planned."""
    from sassi_bench.storage.inventory import session_progress

    found = []
    for folder in run_session_folders(args):
        progress = session_progress(folder)
        if progress is not None and progress[1][0] < progress[1][1]:
            found.append(folder.name)
    return found
