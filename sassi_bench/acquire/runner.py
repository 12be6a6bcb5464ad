"""Run a capture plan on a rig, storing every frame in a session as soon as it exists.

:func:`run_plan` captures the steps a session still misses, in plan order, so an
interrupted capture (crash, Ctrl-C, ``stop_after``) resumes by calling it again with the
same plan and session, possibly on a freshly opened rig. Devices are used only through
the :class:`~sassi_bench.rig.rig.Rig` protocols.

Storing a frame (compression, hash, fsync: :meth:`Session.write_frame`) runs in one
background thread while the next frame is captured, in capture order, with at most
:data:`IN_FLIGHT` frames waiting. The session's invariants do not change: each frame is
still written whole (chunk, then its event) by ``write_frame``; a frame the camera
returned is stored before :func:`run_plan` returns or raises, whatever stopped it (a
Ctrl-C or SIGTERM, which only the main thread receives, a device error); a SIGKILL can
leave at most the frames in flight unlogged, which a resumed run captures again.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections import deque
from collections.abc import Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from sassi_bench._shared.disk import DISK_FULL_FIX, free_bytes
from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.session import Session, SessionError
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.rig.protocols import Camera
from sassi_bench.rig.rig import Rig
from sassi_bench.rig.scene_pose import ScenePose

__all__ = ["IN_FLIGHT", "LEAST_STORED_SHARE", "WRITER_THREAD_PREFIX", "run_plan"]

#: Frames captured but not yet stored, at most (8 MB each at the prototype's scale).
IN_FLIGHT = 2
#: Name prefix of the thread that stores a run's frames.
WRITER_THREAD_PREFIX = "sassi-frame-writer"


def _camera(rig: Rig, name: str) -> Camera:
    return rig.spectral_camera if name == "spectral" else rig.guide_camera


@contextlib.contextmanager
def _sigint_deferred() -> Iterator[None]:
    """Hold Ctrl-C until the block ends, so a frame and its event are stored whole."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    try:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    except ValueError:  # pragma: no cover - signals unavailable in this interpreter
        yield
        return
    try:
        yield
    finally:
        # A handler installed outside Python reads back as None; restore the default then.
        signal.signal(
            signal.SIGINT, previous if previous is not None else signal.default_int_handler
        )
    if received and previous is not signal.SIG_IGN:  # a background job ignores Ctrl-C
        raise KeyboardInterrupt


class _FrameWriter:
    """Stores a run's frames in one background thread, in the order they are given.

    :meth:`put` waits while :data:`IN_FLIGHT` frames are pending and raises the first
    failed write; :meth:`close` waits for every pending frame (a Ctrl-C meanwhile is held
    until they are stored) and raises the first failure. After a failure, frames still
    queued are not written (a resumed run captures them).
    """

    def __init__(self, session: Session, stored: Any) -> None:
        self._session = session
        self._stored = stored
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix=WRITER_THREAD_PREFIX)
        self._pending: deque[Future[None]] = deque()
        self._failed = threading.Event()

    def _write(self, step_index: int, frame: Any) -> None:
        if self._failed.is_set():
            return
        try:
            self._session.write_frame(step_index, frame)
        except BaseException:
            self._failed.set()
            raise

    def put(self, step_index: int, frame: Any) -> None:
        """Queue ``frame`` of step ``step_index`` for storing."""
        self._pending.append(self._pool.submit(self._write, step_index, frame))
        while len(self._pending) > IN_FLIGHT or (self._pending and self._pending[0].done()):
            self._collect()

    def _collect(self) -> None:
        # Taken off the queue only once stored: a Ctrl-C while waiting leaves it for close.
        self._pending[0].result()
        self._pending.popleft()
        self._stored()

    def close(self) -> None:
        """Wait until every queued frame is stored; raise the first failed write."""
        error: BaseException | None = None
        with _sigint_deferred():
            while self._pending:
                try:
                    self._collect()
                except BaseException as exc:
                    self._pending.popleft()
                    error = error or exc
            self._pool.shutdown(wait=True)
        if error is not None:
            raise error


#: The least share of its raw bytes a stored frame takes (Blosc zstd after a byte shuffle;
#: a margin under every share measured on the virtual rigs' frames:
#: ``docs/notes/2026-12-01-measured-in-code-comments.md``). A run whose frames would not fit on
#: the disk even at this share is refused before it starts; one that fits at it and still
#: fills the disk stops at the frame that did not fit.
LEAST_STORED_SHARE = 0.25


def _raw_bytes(camera: Camera) -> int:
    """Bytes of one of ``camera``'s frames before compression."""
    return int(np.prod(camera.shape)) * (1 if camera.bit_depth <= 8 else 2)


def _check_disk(rig: Rig, plan: Plan, session: Session, todo: tuple[int, ...]) -> None:
    """Refuse a run whose frames cannot fit on the session's disk, before any device moves."""
    raw = {name: _raw_bytes(_camera(rig, name)) for name in {plan.steps[i].camera for i in todo}}
    need = LEAST_STORED_SHARE * sum(raw[plan.steps[i].camera] for i in todo)
    free = free_bytes(session.path)
    if free is not None and need > free:
        raise SessionError(
            step_error(
                f"run plan {plan.name!r}",
                f"its {len(todo)} frames to capture take at least {need / 1e6:.0f} MB, and the "
                f"disk holding {session.path} has {free / 1e6:.0f} MB free",
                DISK_FULL_FIX,
            )
        )


def _check_inputs(rig: Rig, plan: Plan, session: Session, todo: tuple[int, ...]) -> None:
    """Refuse a mismatched session and catch bad steps before any device moves."""
    if session.plan_sha256 != plan.sha256():
        raise SessionError(
            step_error(
                f"run plan {plan.name!r}",
                f"session {session.id!r} was created for plan {session.plan.name!r} "
                f"(sha256 {session.plan_sha256[:12]}), not this one",
                "pass the session's own plan (session.plan) or create a new session",
            )
        )
    if session.rig_sha256 != rig.description.sha256():
        raise SessionError(
            step_error(
                f"run plan {plan.name!r}",
                f"session {session.id!r} was captured on another rig description "
                f"({session.rig.get('name')!r}, sha256 {session.rig_sha256[:12]})",
                "open the rig the session was made for, or create a new session",
            )
        )
    for i in todo:
        step = plan.steps[i]
        lo, hi = _camera(rig, step.camera).exposure_range_s
        if not lo <= step.exposure_s <= hi:
            raise ProcedureError(
                step_error(
                    f"run plan {plan.name!r} step {i}",
                    f"exposure {step.exposure_s:g} s is outside the {step.camera} camera's "
                    f"range [{lo:g}, {hi:g}] s",
                    "fix the plan's exposure (seconds)",
                )
            )
        try:
            render_pattern(step.pattern, rig.slm.shape)
        except (ValueError, KeyError, TypeError) as exc:
            raise ProcedureError(
                step_error(
                    f"run plan {plan.name!r} step {i}",
                    f"pattern {dict(step.pattern)!r} cannot be rendered ({exc})",
                    "fix the step's pattern descriptor (see sassi_bench.acquire.patterns)",
                )
            ) from exc


def run_plan(
    rig: Rig,
    plan: Plan,
    session: Session,
    *,
    progress: bool = True,
    stop_after: int | None = None,
    steps: Iterable[int] | None = None,
) -> Session:
    """Capture the steps of ``plan`` that ``session`` still misses, in order.

    For each step: select its light (when it changed), set its camera's exposure,
    show its pattern on the SLM, capture, and store the frame with
    :meth:`Session.write_frame` (in a background thread, while the next step is
    captured; see the module's notes). The trigger is armed for the run and always disarmed
    at the end. If ``plan.parameters`` has a ``"scene"``, that scene is put in front of
    the bench first (so a resumed run on a fresh rig sees the same scene), at the
    pose ``"scene_pose"`` (a :class:`~sassi_bench.rig.scene_pose.ScenePose` dict) when
    the plan has one.

    Parameters
    ----------
    rig
        Device handles (``sassi_bench.open_rig(...)``).
    plan
        The plan; must be the session's plan.
    session
        Where frames go; steps already in ``session.completed`` are skipped.
    progress
        Show a tqdm progress bar (terminal or notebook) over the whole plan.
    stop_after
        Stop after this many new frames (``None``: run to the end).
    steps
        Capture only these steps of the plan (``None``: every step), for a procedure that
        plans a budget and decides from the frames so far whether to take more.

    Returns
    -------
    Session
        ``session``, with the new frames.

    Raises
    ------
    SessionError
        If ``session`` was made for another plan or rig, or its disk cannot hold the
        frames still to capture (:data:`LEAST_STORED_SHARE`).
    SessionLockedError
        If another process (or session object) is writing the session.
    ValueError
        If a remaining step's exposure or pattern is invalid (checked before capturing).
    KeyboardInterrupt
        Re-raised once every frame captured so far is stored; run again to resume.

    Examples
    --------
    >>> import tempfile
    >>> from sassi_bench import open_rig
    >>> from sassi_bench.acquire.plan import Plan, Step
    >>> tmp = tempfile.TemporaryDirectory()
    >>> rig = open_rig("sim")
    >>> plan = Plan("dark", [Step("spectral", "off", 0.01, {"kind": "blank"})] * 2)
    >>> session = Session.create(rig.description, plan, session_id="dark", data=tmp.name)
    >>> run_plan(rig, plan, session, progress=False, stop_after=1).missing
    (1,)
    >>> run_plan(rig, plan, session, progress=False, steps=[0]).missing
    (1,)
    >>> run_plan(rig, plan, session, progress=False).is_complete
    True
    >>> tmp.cleanup()
    """
    with session.writing():  # one writer per session, across processes
        return _capture(rig, plan, session, progress=progress, stop_after=stop_after, steps=steps)


def _capture(
    rig: Rig,
    plan: Plan,
    session: Session,
    *,
    progress: bool,
    stop_after: int | None,
    steps: Iterable[int] | None = None,
) -> Session:
    """:func:`run_plan` with the session locked for writing."""
    if stop_after is not None and (
        isinstance(stop_after, bool) or not isinstance(stop_after, int) or stop_after < 0
    ):
        raise ProcedureError(
            step_error(
                f"run plan {plan.name!r}",
                f"stop_after={stop_after!r} is not a non-negative integer",
                "pass None to run to the end, or a number of frames",
            )
        )
    todo = session.missing
    total, initial = len(plan), len(plan) - len(todo)
    if steps is not None:
        wanted = set(steps)
        todo = tuple(i for i in todo if i in wanted)
        # The bar counts the chosen steps only.
        total = len(wanted)
        initial = total - len(todo)
    _check_inputs(rig, plan, session, todo)
    if stop_after is not None:
        todo = todo[:stop_after]
    if not todo:  # a complete session: no scene to place, no light to switch, no trigger
        return session
    _check_disk(rig, plan, session, todo)
    bar: Any = tqdm(
        total=total,
        initial=initial,
        desc=plan.name,
        unit="frame",
        disable=not progress,
    )
    light: str | None = None
    writer = _FrameWriter(session, lambda: bar.update(1))
    rig.trigger.arm()
    try:
        try:
            scene = plan.parameters.get("scene")
            if scene is not None:
                pose = plan.parameters.get("scene_pose")
                rig.set_scene(scene, None if pose is None else ScenePose.from_dict(pose))
            for i in todo:
                step = plan.steps[i]
                camera = _camera(rig, step.camera)
                if step.light != light:
                    rig.light.select(step.light)
                    light = step.light
                if camera.exposure_s != step.exposure_s:
                    camera.set_exposure(step.exposure_s)
                rig.slm.show(render_pattern(step.pattern, rig.slm.shape))
                writer.put(i, camera.capture())
        finally:
            writer.close()  # every frame captured so far is stored first
    except KeyboardInterrupt:
        if progress:
            bar.write(
                f"{plan.name}: interrupted; {len(session.completed)}/{len(plan)} frames are "
                f"stored in {session.path} and kept; a run with this session resumes there."
            )
        raise
    finally:
        rig.trigger.disarm()
        bar.close()
    return session
