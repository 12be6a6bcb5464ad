"""Raw capture sessions on disk: Zarr v3 frames plus an append-only JSON event log.

Layout of ``<data_root>/sessions/<session_id>/``, one module per part:

::

    session.json     written once: schema, id, created (UTC), rig description and plan
                     (each with its SHA-256), software version            (header)
    frames.zarr/     Zarr v3 group; one array per camera the plan uses, one chunk per
                     frame: ``spectral`` (n, H, W), ``guide`` (n, H, W, 3); a step's slot
                     is its rank among the plan's steps for that camera   (frames)
    events.jsonl     one JSON line per stored frame, appended and fsync'd after its
                     chunk, so an event exists only for a fully written frame, with the
                     frame's SHA-256, read checksum and chunk size (events)
    events.torn      (only after a crash) bytes of a torn last event line, kept aside
    retakes.jsonl    (only once frames were set aside) the events whose damaged frames
                     are to be captured again                            (events)
    damaged/         (idem) the damaged chunk files, kept as they were found
    write.lock       advisory lock of the session's writer (``fcntl.flock``), holding
                     its pid, host, command and start time (_shared.lock)

:mod:`~sassi_bench.acquire.session.folder` makes and finds session folders;
:class:`Session` (in :mod:`~sassi_bench.acquire.session.session`) puts the parts together.

A camera's array is created when its first frame is written, with that frame's shape
and dtype; later frames must match. A step is *completed* when its event is in the log.
A torn last line (a crash while appending) is ignored, reported as a
:class:`SessionWarning`, and moved to ``events.torn`` before the next append; its step
is simply captured again. Completed steps are never overwritten. Metadata is JSON only.

Every frame read back is checked against its event (shape and checksum): a frame that is
missing (its chunk file gone, which Zarr would read as zeros), truncated, undecodable or
changed raises :class:`FrameDamagedError` naming the session, the step, the chunk file and
what is wrong. :meth:`Session.verify` and :meth:`Session.find_damage` check every frame
on demand; :meth:`Session.set_aside` moves damaged frames to ``damaged/`` so that the
capture, resumed, takes them again. A session whose ``session.json``, event log or frame
store cannot be read raises :class:`SessionDamagedError` when opened or resumed, saying
what is unreadable and what the frames and the log still hold
(:mod:`~sassi_bench.acquire.session.salvage`).

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
>>> import numpy as np
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

from sassi_bench.acquire.session.errors import (
    FrameDamage,
    FrameDamagedError,
    SessionDamagedError,
    SessionError,
    SessionIntegrityError,
    SessionLockedError,
    SessionWarning,
)
from sassi_bench.acquire.session.frames import frame_checksum, frame_sha256
from sassi_bench.acquire.session.header import SCHEMA_NAME, SCHEMA_VERSION, check_session_id
from sassi_bench.acquire.session.session import Session

__all__ = [
    "SCHEMA_NAME",
    "SCHEMA_VERSION",
    "FrameDamage",
    "FrameDamagedError",
    "Session",
    "SessionDamagedError",
    "SessionError",
    "SessionIntegrityError",
    "SessionLockedError",
    "SessionWarning",
    "check_session_id",
    "frame_checksum",
    "frame_sha256",
]
