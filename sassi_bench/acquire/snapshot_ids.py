"""Snapshot ids: one form for every ``sassi-bench snapshot`` command.

``snapshot take --session ID`` stores a video as raw sessions ``<ID>-preview`` and
``<ID>-f000``, ``<ID>-f001``, ... (:mod:`sassi_bench.acquire.snapshots`). Every command
that reads snapshots accepts either the video's id ``ID`` (every complete frame) or one
frame's id ``ID-fNNN`` (that frame): :func:`resolve_snapshot` tells them apart.

Examples
--------
>>> snapshot_ids("/nonexistent")
[]
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from sassi_bench.acquire.session import Session, SessionDamagedError, SessionError
from sassi_bench.acquire.snapshots import SnapshotVideo
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.paths import data_root

__all__ = [
    "SnapshotSelection",
    "open_snapshots",
    "resolve_snapshot",
    "snapshot_ids",
    "unknown_snapshot",
]

_FRAME_ID = re.compile(r"^(?P<prefix>.+)-f(?P<number>\d{3})$")


def open_snapshots(
    prefix: str, *, data: str | os.PathLike[str] | None = None, step: str = "snapshot reconstruct"
) -> SnapshotVideo:
    """The sessions of a snapshot video taken before: ``<prefix>-preview`` and its frames.

    Parameters
    ----------
    prefix
        The ``--session`` the snapshots were taken with.
    data
        Data root the sessions are under.
    step
        The command named in errors.

    Returns
    -------
    SnapshotVideo
        The preview and the complete frames ``<prefix>-f000``, ``-f001``, ... up to the
        first missing or incomplete one.

    Raises
    ------
    ProcedureError
        If there is no preview session, or no complete frame.

    Examples
    --------
    Not run here (it drives a bench or reads its sessions)::

        video = open_snapshots("snap", data="calib_data")
    """
    root = data_root(data) / "sessions"
    try:
        preview = Session.open(f"{prefix}-preview", data=data)
    except SessionDamagedError:
        raise  # it is there but damaged: the error says what is unreadable
    except SessionError as exc:
        raise ProcedureError(
            step_error(
                step,
                f"no snapshot session {prefix!r} under {root} (no {prefix}-preview session)",
                "give the --session of `sassi-bench snapshot take` (or of a `validate "
                "snapshot` run, e.g. <prefix>-adaptive), and the same --data",
            )
        ) from exc
    pattern = re.compile(re.escape(prefix) + r"-f(\d{3})$")
    numbers = sorted(
        int(m.group(1)) for p in root.iterdir() if (m := pattern.match(p.name)) and p.is_dir()
    )
    frames = []
    for t in range(len(numbers)):
        if numbers[t] != t:
            break  # frames are taken in order: a gap ends the video
        session = Session.open(f"{prefix}-f{t:03d}", data=data)
        if not session.is_complete:
            break
        frames.append(session)
    if not frames:
        raise ProcedureError(
            step_error(
                step,
                f"snapshot {prefix!r} has a preview but no complete frame",
                f"resume the capture: `sassi-bench snapshot take --session {prefix}`",
            )
        )
    return SnapshotVideo(preview, tuple(frames))


@dataclass(frozen=True)
class SnapshotSelection:
    """A snapshot video and the frames a snapshot id chose of it.

    Attributes
    ----------
    prefix
        The video's id (``<prefix>-preview``, ``<prefix>-fNNN``).
    video
        Its sessions (every complete frame: the frames before a chosen one plan its mask).
    frames
        Indices into ``video.frames`` chosen (all of them for a prefix, one for a frame id).
    by_frame
        Whether the id named one frame (``<prefix>-fNNN``) rather than the video.
    """

    prefix: str
    video: SnapshotVideo
    frames: tuple[int, ...]
    by_frame: bool

    @property
    def sessions(self) -> list[Session]:
        """The chosen frames' sessions."""
        return [self.video.frames[t] for t in self.frames]


def _is_session(root: Path, name: str) -> bool:
    return (root / name / "session.json").is_file()


def snapshot_ids(data: str | os.PathLike[str] | None = None) -> list[str]:
    """The snapshot videos under the data root (the prefixes of ``<prefix>-preview``).

    Parameters
    ----------
    data
        Data root.

    Returns
    -------
    list of str
        The videos' ids, sorted; empty when there is no sessions folder.

    Examples
    --------
    >>> snapshot_ids("/nonexistent")
    []
    """
    root = data_root(data) / "sessions"
    if not root.is_dir():
        return []
    return sorted(
        p.name.removesuffix("-preview")
        for p in root.iterdir()
        if p.name.endswith("-preview") and (p / "session.json").is_file()
    )


def resolve_snapshot(
    snapshot_id: str,
    *,
    data: str | os.PathLike[str] | None = None,
    step: str = "snapshot",
    required: bool = True,
) -> SnapshotSelection | None:
    """The frames a snapshot id names: a prefix (every complete frame of the video) or a
    frame's id ``<prefix>-fNNN`` (that frame), as ``sassi-bench snapshot take`` prints them.

    A prefix is tried first, so a prefix that itself ends in ``-fNNN`` still names its
    video. The folder of one of its sessions (``<data>/sessions/<id>``) works like its
    id, in the data root that holds it.

    Parameters
    ----------
    snapshot_id
        Prefix, frame id, or the folder of one of the video's sessions.
    data
        Data root.
    step
        The command named in errors.
    required
        Raise when no snapshot has that id (else return None: the caller may try a plain
        raw session).

    Returns
    -------
    SnapshotSelection or None
        The video and the chosen frames; None when ``required`` is false and no
        snapshot has that id.

    Raises
    ------
    ProcedureError
        If no snapshot has that id (and ``required``), or the frame named was not taken
        to the end.

    Examples
    --------
    >>> resolve_snapshot("snap", data="/nonexistent", required=False) is None
    True
    """
    name = str(snapshot_id)
    if os.sep in name:  # a session's folder: its name, in the data root that holds it
        folder = Path(name)
        name = folder.name
        if folder.parent.name == "sessions" and folder.parent.is_dir():
            data = folder.parent.parent
    root = data_root(data) / "sessions"
    name = name.removesuffix("-preview")
    if _is_session(root, f"{name}-preview"):
        video = open_snapshots(name, data=data, step=step)
        return SnapshotSelection(name, video, tuple(range(len(video.frames))), False)
    match = _FRAME_ID.match(name)
    if match and _is_session(root, f"{match['prefix']}-preview"):
        prefix, number = match["prefix"], int(match["number"])
        video = open_snapshots(prefix, data=data, step=step)
        if number >= len(video.frames):
            last = len(video.frames) - 1
            complete = f"{prefix}-f000" + (f"..{prefix}-f{last:03d}" if last else "")
            raise ProcedureError(
                step_error(
                    step,
                    f"frame {name!r} of snapshot {prefix!r} was not taken to the end (its "
                    f"complete frames: {complete})",
                    f"choose one of those, or resume the capture: `sassi-bench snapshot take "
                    f"--session {prefix}`",
                )
            )
        return SnapshotSelection(prefix, video, (number,), True)
    if not required:
        return None
    raise unknown_snapshot(snapshot_id, data=data, step=step)


def unknown_snapshot(
    snapshot_id: str, *, data: str | os.PathLike[str] | None = None, step: str = "snapshot"
) -> ProcedureError:
    """The error for an id that names no snapshot: it lists the snapshots there are.

    Parameters
    ----------
    snapshot_id
        The id given.
    data
        Data root.
    step
        The command named in the error.

    Returns
    -------
    ProcedureError
        The error to raise (up to ten of the snapshots there are are named).

    Examples
    --------
    >>> print(unknown_snapshot("snp", data="/nonexistent"))  # doctest: +ELLIPSIS
    snapshot: no snapshot 'snp' under /nonexistent/sessions. Fix: give the id ... none
    """
    known = snapshot_ids(data)
    listed = ", ".join(known[:10]) + (" ..." if len(known) > 10 else "") if known else "none"
    return ProcedureError(
        step_error(
            step,
            f"no snapshot {snapshot_id!r} under {data_root(data) / 'sessions'}",
            "give the id `sassi-bench snapshot take` printed (the video, e.g. snap, or one "
            f"frame, e.g. snap-f000) and the same --data; snapshots there: {listed}",
        )
    )
