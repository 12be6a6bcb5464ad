"""An inventory of the data root: sessions, staging folders, bundles and reports.

::

    <data>/sessions/<id>/                    raw sessions of single commands (scan, ...)
    <data>/staging/<run>/sessions/<id>/      raw sessions of a calibration chain
    <data>/staging/<run>/<rig>/vNNNN/        its intermediate bundles
    <data>/<rig>/vNNNN/                      published bundles (never cleaned)
    <data>/reports/<run>/                    copies of the chain's reports

A session is *used* by every published bundle that lists its id among its ``inputs``.
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

__all__ = ["DataEntry", "folder_size", "format_size", "inventory", "session_users"]


@dataclass(frozen=True)
class DataEntry:
    """One folder of the data root.

    Attributes
    ----------
    kind
        ``"session"``, ``"staged-bundles"``, ``"bundle"`` or ``"report"``.
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
    """

    kind: str
    name: str
    path: Path
    size_bytes: int
    modified: datetime
    used_by: tuple[str, ...] = ()


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


def _entry(kind: str, root: Path, path: Path, used_by=()) -> DataEntry:
    size, newest = folder_size(path)
    modified = datetime.fromtimestamp(newest or path.stat().st_mtime, UTC)
    return DataEntry(kind, path.relative_to(root).as_posix(), path, size, modified, used_by)


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


def _folders(path: Path) -> list[Path]:
    return sorted(p for p in path.iterdir() if p.is_dir() and not p.is_symlink())


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
    return entries
