"""An inventory of the data root: sessions, staging folders, bundles and reports.

::

    <data>/sessions/<id>/                    raw sessions of single commands (scan, ...)
    <data>/staging/<run>/sessions/<id>/      raw sessions of a calibration chain
    <data>/staging/<run>/<rig>/vNNNN/        its intermediate bundles
    <data>/<rig>/vNNNN/                      published bundles (never cleaned)
    <data>/reports/<run>/                    copies of the chain's reports

A session is *used* by every published bundle that lists its id among its ``inputs``. Its
plan name and how many of its planned frames are stored are read from ``session.json``
and ``events.jsonl`` (an incomplete session is an interrupted capture that resumes). A
session whose header or log does not read, or whose frames are missing or damaged, is
marked with what is wrong (:func:`~sassi_bench.storage.integrity.session_damage`).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from sassi_bench.bundle.integrity import MANIFEST_NAME
from sassi_bench.bundle.layout import rig_dir, rig_names, version_number, versions
from sassi_bench.paths import data_root
from sassi_bench.storage.integrity import session_damage

__all__ = [
    "MEASUREMENT_PLANS",
    "DataEntry",
    "folder_size",
    "format_size",
    "inventory",
    "session_progress",
    "session_users",
]

#: Plans that measure a scene for its own sake (reference scans, snapshots), as
#: opposed to calibration captures; a plan name is matched up to its first ``-f``.
MEASUREMENT_PLANS = ("pinhole-scan", "snapshot-preview", "snapshot-f")


@dataclass(frozen=True)
class DataEntry:
    """One folder of the data root.

    Attributes
    ----------
    kind
        ``"session"``, ``"staged-bundles"``, ``"bundle"``, ``"report"`` or ``"leftover"``
        (a hidden temporary folder an interrupted write or removal left behind).
    name
        Its name relative to the data root (``sessions/scan-x``, ``sim/v0002``...).
    path
        The folder.
    size_bytes
        Bytes of every file below it.
    modified
        Newest modification time below it (UTC).
    used_by
        Published bundles (``rig/version``) that list this session as an input.
    plan
        A session's plan name (None: not a session, or unreadable).
    frames
        A session's stored and planned frames (None: not a session, or unreadable).
    damage
        What is wrong with a session, in words (None: nothing seen; see
        :func:`~sassi_bench.storage.integrity.session_damage`).
    """

    kind: str
    name: str
    path: Path
    size_bytes: int
    modified: datetime
    used_by: tuple[str, ...] = ()
    plan: str | None = None
    frames: tuple[int, int] | None = None
    damage: str | None = None

    @property
    def damaged(self) -> bool:
        """A session whose header or log does not read, or with frames missing or damaged."""
        return self.damage is not None

    @property
    def staged(self) -> bool:
        """Whether it lies in a calibration chain's staging folder."""
        return self.name.startswith("staging/")

    @property
    def incomplete(self) -> bool:
        """A session with fewer frames stored than planned: an interrupted capture."""
        return self.frames is not None and self.frames[0] < self.frames[1]

    @property
    def measurement(self) -> bool:
        """A session that measured a scene for its own sake (a scan or a snapshot taken by
        a command, not inside a calibration chain)."""
        return (
            self.kind == "session"
            and not self.staged
            and self.plan is not None
            and self.plan.startswith(MEASUREMENT_PLANS)
        )


def folder_size(path: Path) -> tuple[int, float]:
    """Total bytes and newest mtime (POSIX seconds) of the files below ``path``.

    Examples
    --------
    >>> folder_size(Path("/nonexistent"))
    (0, 0.0)
    """
    total, newest = 0, 0.0
    for root, _, files in os.walk(path):
        for name in files:
            try:
                stat = os.lstat(os.path.join(root, name))
            except OSError:
                continue
            total += stat.st_size
            newest = max(newest, stat.st_mtime)
    return total, newest


def format_size(size: int) -> str:
    """Bytes in a unit a person reads.

    Examples
    --------
    >>> format_size(512), format_size(3_400_000), format_size(2 * 1024**3)
    ('512 B', '3.2 MB', '2.0 GB')
    """
    value = float(size)
    for unit in ("B", "kB", "MB", "GB"):
        if value < 1024 or unit == "GB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.1f} {unit}"
        value /= 1024
    raise AssertionError("unreachable")


def session_progress(folder: Path) -> tuple[str, tuple[int, int]] | None:
    """A session folder's plan name and (stored, planned) frames, read without verifying
    the frames (frames set aside to be captured again are not stored); None when its
    ``session.json`` cannot be read.

    Examples
    --------
    >>> session_progress(Path("/nonexistent")) is None
    True
    """
    try:
        plan = json.loads((folder / "session.json").read_bytes())["plan"]
        name, planned = str(plan["name"]), len(plan["steps"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    aside = set()
    try:
        with open(folder / "retakes.jsonl", "rb") as retakes:
            for line in retakes:
                try:
                    record = json.loads(line)
                    aside.add((record["step"], record["sha256"], record.get("written")))
                except (ValueError, KeyError, TypeError):
                    continue
    except OSError:
        pass
    stored: set[int] = set()
    try:
        with open(folder / "events.jsonl", "rb") as log:
            for line in log:
                try:
                    event = json.loads(line)
                    key = (event["step"], event["sha256"], event.get("written"))
                    if key in aside:  # set aside to be captured again
                        stored.discard(int(event["step"]))
                    else:
                        stored.add(int(event["step"]))
                except (ValueError, KeyError, TypeError):
                    continue  # a torn last line: that frame is captured again on resume
    except OSError:
        pass
    return name, (len(stored), planned)


def _entry(kind: str, root: Path, path: Path, used_by=()) -> DataEntry:
    size, newest = folder_size(path)
    modified = datetime.fromtimestamp(newest or path.stat().st_mtime, UTC)
    name = path.relative_to(root).as_posix()
    if kind != "session":
        return DataEntry(kind, name, path, size, modified, used_by)
    plan, frames = session_progress(path) or (None, None)
    return DataEntry(kind, name, path, size, modified, used_by, plan, frames, session_damage(path))


def session_users(data: str | os.PathLike[str] | None = None) -> dict[str, tuple[str, ...]]:
    """Session id -> the published bundles (``rig/version``) that use it as an input.

    Manifests are read without verifying the bundles (``sassi-bench bundle verify`` does).

    Examples
    --------
    >>> session_users("/nonexistent")
    {}
    """
    users: dict[str, list[str]] = {}
    for rig in rig_names(data):
        folder = rig_dir(rig, data)
        for version in versions(folder):
            try:
                manifest = json.loads((folder / version / MANIFEST_NAME).read_text("utf-8"))
                ids = [str(item["id"]) for item in manifest.get("inputs", [])]
            except (OSError, ValueError, TypeError, KeyError):
                continue
            for session_id in ids:
                users.setdefault(session_id, []).append(f"{rig}/{version}")
    return {key: tuple(value) for key, value in users.items()}


#: A leftover temporary folder is only listed once it is this old (a running writer
#: renames its own into place within moments).
LEFTOVER_AGE_S = 3600.0


def _folders(path: Path) -> list[Path]:
    return sorted(
        p
        for p in path.iterdir()
        if p.is_dir() and not p.is_symlink() and not p.name.startswith(".")
    )


def _leftovers(path: Path, now: float) -> list[Path]:
    """Hidden temporary folders (``.<name>.<hex>.tmp``, ``.publish-*``, ``.import-*``)
    an interrupted write or removal left in ``path``."""
    if not path.is_dir():
        return []
    found = []
    for p in path.iterdir():
        hidden = p.name.startswith(".") and (
            p.name.endswith(".tmp") or p.name.startswith((".publish-", ".import-"))
        )
        if not hidden or not p.is_dir() or p.is_symlink():
            continue
        if now - max(folder_size(p)[1], p.stat().st_mtime) > LEFTOVER_AGE_S:
            found.append(p)
    return sorted(found)


def inventory(data: str | os.PathLike[str] | None = None) -> list[DataEntry]:
    """Every session, staged-bundle folder, published bundle and report under the data root.

    Examples
    --------
    >>> inventory("/nonexistent")
    []
    """
    root = data_root(data)
    if not root.is_dir():
        return []
    users = session_users(root)
    entries: list[DataEntry] = []

    def sessions(folder: Path) -> None:
        if folder.is_dir():
            for path in _folders(folder):
                entries.append(_entry("session", root, path, users.get(path.name, ())))

    sessions(root / "sessions")
    if (root / "staging").is_dir():
        for run in _folders(root / "staging"):
            sessions(run / "sessions")
            for rig in _folders(run):
                if rig.name != "sessions":
                    entries.append(_entry("staged-bundles", root, rig))
    for rig in rig_names(root):
        for version in versions(rig_dir(rig, root)):
            if version_number(version) is not None:
                entries.append(_entry("bundle", root, rig_dir(rig, root) / version))
    if (root / "reports").is_dir():
        entries.extend(_entry("report", root, path) for path in _folders(root / "reports"))
    now = datetime.now(UTC).timestamp()
    places = [root / "sessions", root / "staging", *(rig_dir(r, root) for r in rig_names(root))]
    if (root / "staging").is_dir():
        places += [run / "sessions" for run in _folders(root / "staging")]
    for place in places:
        entries.extend(_entry("leftover", root, path) for path in _leftovers(place, now))
    return entries
