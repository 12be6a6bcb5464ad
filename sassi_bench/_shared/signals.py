"""Holding a stop signal back until a write that must not be cut is done.

A Ctrl-C (or SIGTERM, SIGHUP) raised inside some libraries' writers cannot be recovered
from: xarray's NetCDF writer holds the HDF5 library's lock while it writes, and the
exception's clean-up (closing the file) waits on that same lock for ever. Around such a
write, :func:`deferred_stop_signals` notes a stop signal instead, and delivers it to the
handler that was in place as soon as the write is over, where it stops the run as usual.

Examples
--------
>>> import os, signal
>>> previous = signal.signal(signal.SIGTERM, lambda n, f: print("stopped after the write"))
>>> with deferred_stop_signals():
...     os.kill(os.getpid(), signal.SIGTERM)  # noted, not acted on here
...     print("write finished")
write finished
stopped after the write
>>> _ = signal.signal(signal.SIGTERM, previous)
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

__all__ = ["STOP_SIGNALS", "deferred_stop_signals"]

#: The signals a lab uses to stop a run: Ctrl-C, ``kill``/``timeout``, a closed terminal.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


@contextlib.contextmanager
def deferred_stop_signals() -> Iterator[None]:
    """Defer SIGINT, SIGTERM and SIGHUP to the end of the block, then deliver the first.

    Outside the main thread (where Python runs no signal handlers) this does nothing.
    A signal whose handler was ``SIG_DFL`` is raised again with its default action; an
    ignored one stays ignored.

    Yields
    ------
    None

    Examples
    --------
    >>> with deferred_stop_signals():
    ...     pass
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = {signum: signal.getsignal(signum) for signum in STOP_SIGNALS}
    for signum in STOP_SIGNALS:
        signal.signal(signum, lambda number, frame: received.append(number))
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
        if received:
            signum = received[0]
            handler = previous[signum]
            if callable(handler):
                handler(signum, None)
            elif handler == signal.SIG_DFL:
                signal.raise_signal(signum)
