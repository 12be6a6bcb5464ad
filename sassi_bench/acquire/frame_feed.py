"""Process a session's frames as the session fills, in plan order, identically on resume.

A procedure that captures and then processes reads every frame back from its session
after the capture. :class:`FrameFeed` instead hands each frame to a consumer (a decoder,
a scan's reading pass) as soon as it is stored, on a worker thread, so processing
overlaps the capture and no frame is read back: :meth:`FrameFeed.tee` is the session as
:func:`~sassi_bench.acquire.runner.run_plan` should write it, and every frame it stores
is also queued for the consumer. Frames stored before this run (a resumed capture, or a
session captured earlier) are read back from the session when their turn comes.

The consumer sees the wanted steps in plan order whatever happened before (steps already
stored, steps captured now), so its result does not depend on where a capture was
interrupted: it is the result of processing the session after its capture. A consumer
error stops the capture at its next frame (the frame is stored first) and is raised by
:meth:`FrameFeed.finish`; leaving the ``with`` block early (Ctrl-C) stops the worker.
The queue holds at most ``depth`` frames, so a slow consumer holds the capture back
rather than filling memory.
"""

from __future__ import annotations

import contextlib
import queue
import threading
from collections.abc import Callable, Iterable
from typing import Any

from numpy.typing import NDArray

from sassi_bench.acquire.session import Session
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["THREAD_PREFIX", "FrameFeed"]

#: Name prefix of the feeds' worker threads (a benchmark tells their CPU time apart).
THREAD_PREFIX = "sassi-frame-feed"

_DONE = object()


class _TeeSession:
    """A session that also hands every frame it stores to its feed."""

    def __init__(self, session: Session, feed: FrameFeed) -> None:
        self._session = session
        self._feed = feed

    def write_frame(self, step_index: int, frame: Any) -> None:
        self._session.write_frame(step_index, frame)
        self._feed.offer(step_index, frame.data)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._session, name)


class FrameFeed:
    """Hand the frames of ``steps`` of a session to ``consume(step, frame)`` in plan order.

    Parameters
    ----------
    session
        The session, complete or still to be captured.
    steps
        Step indices the consumer wants (any order; fed in plan order).
    consume
        Called with each wanted step's index and its frame (a read-only array), once per
        step, in plan order, on the worker thread (or the caller's with ``threaded=False``).
    threaded
        Run the consumer on a worker thread; else in the thread that stores or finishes.
    depth
        Frames queued for the worker at most.
    label
        Names the feed in errors and its thread.

    Examples
    --------
    >>> import tempfile
    >>> import numpy as np
    >>> from sassi_bench.acquire.plan import Plan, Step
    >>> from sassi_bench.rig import Frame, FrameMeta, load_rig_description
    >>> tmp = tempfile.TemporaryDirectory()
    >>> plan = Plan("p", [Step("spectral", "off", 1, {"kind": "blank"})] * 3)
    >>> session = Session.create(load_rig_description("sim"), plan, session_id="p",
    ...                          data=tmp.name)
    >>> def frame(i):
    ...     return Frame(np.full((2, 2), i, np.uint16), FrameMeta("spectral", 1, 0, i, "off", i))
    >>> session.write_frame(0, frame(0))  # stored before: read back when its turn comes
    >>> seen = []
    >>> with FrameFeed(session, [0, 2], lambda i, f: seen.append((i, int(f[0, 0])))) as feed:
    ...     for i in (1, 2):
    ...         feed.tee().write_frame(i, frame(i))  # as run_plan stores them
    ...     feed.finish()
    >>> seen
    [(0, 0), (2, 2)]
    >>> tmp.cleanup()
    """

    def __init__(
        self,
        session: Session,
        steps: Iterable[int],
        consume: Callable[[int, NDArray[Any]], None],
        *,
        threaded: bool = True,
        depth: int = 2,
        label: str = "frames",
    ) -> None:
        self.session = session
        self._wanted = sorted(set(int(i) for i in steps))
        self._next = 0  # position in _wanted of the next step to consume
        self._consume = consume
        self._label = label
        self._error: BaseException | None = None
        self._stopped = False
        self._queue: queue.Queue | None = None
        self._thread: threading.Thread | None = None
        if threaded:
            self._queue = queue.Queue(maxsize=max(1, depth))
            self._thread = threading.Thread(
                target=self._work, name=f"{THREAD_PREFIX}-{label}", daemon=True
            )
            self._thread.start()

    # -- the capture's side ---------------------------------------------------------
    def tee(self) -> Session:
        """The session to capture into: it stores each frame, then feeds it."""
        return _TeeSession(self.session, self)  # type: ignore[return-value]

    def offer(self, step: int, frame: NDArray[Any]) -> None:
        """Feed step ``step``'s frame (just stored); raises a consumer error raised so far."""
        self._raise()
        if self._queue is None:
            self._feed_until(step, frame)
        else:
            self._put((step, frame))

    def finish(self) -> None:
        """Feed the wanted steps still to come from the session (those stored; missing
        steps are skipped) and wait until the consumer has taken them all.

        Raises
        ------
        Exception
            The consumer's error, if it raised one.
        """
        if self._queue is None:
            self._feed_until(None, None)
        else:
            self._put(_DONE)
            assert self._thread is not None
            self._thread.join()
        self._raise()

    def close(self) -> None:
        """Stop the worker without feeding the rest (after an error or an interruption)."""
        self._stopped = True
        if self._thread is not None and self._thread.is_alive():
            while True:  # make room for the stop mark; frames not yet taken are dropped
                try:
                    self._queue.put_nowait(_DONE)
                    break
                except queue.Full:
                    with contextlib.suppress(queue.Empty):
                        self._queue.get_nowait()
            self._thread.join()

    def __enter__(self) -> FrameFeed:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- the consumer's side --------------------------------------------------------
    def _put(self, item: Any) -> None:
        while True:
            try:
                self._queue.put(item, timeout=0.5)
                return
            except queue.Full:
                if self._thread is None or not self._thread.is_alive():
                    self._raise()
                    return

    def _raise(self) -> None:
        if self._error is not None:
            raise self._error

    def _work(self) -> None:
        while True:
            item = self._queue.get()
            if item is _DONE or self._stopped:
                if item is _DONE and not self._stopped:
                    self._run(None, None)
                return
            self._run(*item)

    def _run(self, step: int | None, frame: NDArray[Any] | None) -> None:
        if self._error is not None:
            return
        try:
            self._feed_until(step, frame)
        except Exception as exc:  # raised to the capture by offer() and finish()
            self._error = exc

    def _feed_until(self, step: int | None, frame: NDArray[Any] | None) -> None:
        """Consume the wanted steps before ``step`` from the session, then ``step``'s
        ``frame`` (``step=None``: every wanted step left that the session holds)."""
        completed = self.session.completed
        while self._next < len(self._wanted) and not self._stopped:
            wanted = self._wanted[self._next]
            if step is not None and wanted > step:
                return
            if wanted == step:
                self._next += 1
                self._consume(wanted, frame)
                return
            if step is not None and wanted not in completed:
                raise ProcedureError(
                    step_error(
                        f"{self._label}: processing frames as they are captured",
                        f"step {step} was stored before step {wanted}, which is missing",
                        "capture the plan's steps in order (run_plan does), or process the "
                        "session once it is complete",
                    )
                )
            self._next += 1
            if wanted in completed:
                self._consume(wanted, self.session.read_frame(wanted))
