"""Choosing and removing what the data root no longer needs.

Published bundles are never removed. Sessions a published bundle lists as an input are
kept unless asked (``include_referenced``): they are the raw evidence of that bundle.
Staging folders' intermediate bundles and sessions no bundle uses are removed; reports
only when asked (a report of an unpublished run is its only record).
"""

from __future__ import annotations

import shutil
from collections.abc import Iterable
from datetime import UTC, datetime, timedelta
from pathlib import Path

from sassi_bench.storage.inventory import DataEntry

__all__ = ["clean_candidates", "remove"]


def clean_candidates(
    entries: Iterable[DataEntry],
    *,
    include_referenced: bool = False,
    reports: bool = False,
    older_than_days: float = 0.0,
    now: datetime | None = None,
) -> list[DataEntry]:
    """The entries ``sassi-bench data clean`` would remove.

    Parameters
    ----------
    entries
        From :func:`~sassi_bench.storage.inventory.inventory`.
    include_referenced
        Also sessions that published bundles use as inputs.
    reports
        Also report folders.
    older_than_days
        Only entries not modified for this long.

    Examples
    --------
    >>> clean_candidates([])
    []
    """
    cutoff = (now or datetime.now(UTC)) - timedelta(days=older_than_days)
    chosen = []
    for entry in entries:
        if entry.modified > cutoff or entry.kind == "bundle":
            continue
        if entry.kind == "session" and entry.used_by and not include_referenced:
            continue
        if entry.kind == "report" and not reports:
            continue
        chosen.append(entry)
    return chosen


def remove(entries: Iterable[DataEntry], root: Path) -> int:
    """Delete the entries' folders (and staging folders left empty); bytes freed."""
    freed = 0
    for entry in entries:
        if entry.kind == "bundle":  # never, whatever the caller passed
            continue
        shutil.rmtree(entry.path)
        freed += entry.size_bytes
    staging = root / "staging"
    if staging.is_dir():
        for run in staging.iterdir():
            for folder in (run / "sessions", run):
                if folder.is_dir() and not any(folder.iterdir()):
                    folder.rmdir()
    return freed
