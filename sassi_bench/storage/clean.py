"""Choosing and removing what the data root no longer needs.

Published bundles are never removed. What a lab measured is kept unless asked, each
kind with its own option:

- sessions a published bundle lists as an input (``include_referenced``): the raw
  evidence of that bundle;
- scans and snapshots taken by commands (``include_measurements``): reference cubes
  and snapshots are measurements in their own right, not calibration by-products;
- sessions of an interrupted run, and any session with fewer frames than planned
  (``include_interrupted``): the run resumes from them. The sessions of a run that is
  still going are never removed;
- damaged sessions (``include_damaged``): a header or log that does not read, frames
  missing or damaged. What is left of them (the frames, the log) is the only copy of a
  measurement until it is restored or taken again; a damaged session that is also a
  bundle input, a measurement or part of an interrupted run needs that option too.

What remains removable: a calibration chain's intermediate (staged) bundles, calibration
captures no published bundle uses (a failed or abandoned calibration), and hidden
leftovers of interrupted writes or removals.
Reports only when asked (a report of an unpublished run is its only record).
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterable, Sequence
from datetime import UTC, datetime, timedelta
from pathlib import Path

from sassi_bench._shared.atomic import temporary_sibling
from sassi_bench.storage.inventory import DataEntry
from sassi_bench.storage.runs import RunRecord

__all__ = ["KEEP_REASONS", "clean_candidates", "keep_reason", "remove"]

#: Why an entry is kept, and the option that removes it anyway (None: nothing does).
KEEP_REASONS = {
    "bundle": ("published bundles", None),
    "running": ("sessions of a run still going", None),
    "referenced": ("sessions that published bundles use as inputs", "--include-referenced"),
    "damaged": ("damaged sessions (see `data verify`)", "--include-damaged"),
    "interrupted": ("sessions of interrupted runs (they resume)", "--include-interrupted"),
    "measurement": ("scans and snapshots taken by commands", "--include-measurements"),
    "report": ("report folders", "--reports"),
    "recent": ("entries newer than --older-than", "a smaller --older-than"),
}


def _owner(entry: DataEntry, runs: Sequence[RunRecord]) -> RunRecord | None:
    """The run an entry belongs to: a session of it, or its staging folder."""
    parts = entry.name.split("/")
    names = {parts[-1]}
    if parts[0] == "staging" and len(parts) > 1:
        names.add(parts[1])
    return next((r for r in runs if any(r.owns(n) for n in names)), None)


def keep_reason(
    entry: DataEntry,
    *,
    include_referenced: bool = False,
    include_measurements: bool = False,
    include_interrupted: bool = False,
    include_damaged: bool = False,
    reports: bool = False,
    cutoff: datetime | None = None,
    runs: Sequence[RunRecord] = (),
) -> str | None:
    """Why ``data clean`` keeps an entry (a key of :data:`KEEP_REASONS`), or None.

    Examples
    --------
    >>> from pathlib import Path
    >>> scan = DataEntry("session", "sessions/scan-x", Path("x"), 1, datetime.now(UTC),
    ...                  plan="pinhole-scan", frames=(501, 501))
    >>> keep_reason(scan), keep_reason(scan, include_measurements=True) is None
    ('measurement', True)
    >>> broken = DataEntry("session", "sessions/old", Path("x"), 1, datetime.now(UTC),
    ...                    damage="session.json is not JSON")
    >>> keep_reason(broken), keep_reason(broken, include_damaged=True) is None
    ('damaged', True)
    """
    if entry.kind == "bundle":
        return "bundle"
    owner = _owner(entry, runs)
    if owner is not None and owner.state == "running":
        return "running"
    if cutoff is not None and entry.modified > cutoff:
        return "recent"
    if entry.kind == "leftover":
        return None
    if entry.kind == "report":
        return None if reports else "report"
    if entry.damaged and not include_damaged:
        return "damaged"
    if entry.used_by and not include_referenced:
        return "referenced"
    if (owner is not None or entry.incomplete) and not include_interrupted:
        return "interrupted"
    if entry.measurement and not include_measurements:
        return "measurement"
    return None


def clean_candidates(
    entries: Iterable[DataEntry],
    *,
    include_referenced: bool = False,
    include_measurements: bool = False,
    include_interrupted: bool = False,
    include_damaged: bool = False,
    reports: bool = False,
    older_than_days: float = 0.0,
    runs: Sequence[RunRecord] = (),
    now: datetime | None = None,
) -> list[DataEntry]:
    """The entries ``sassi-bench data clean`` would remove (see :func:`keep_reason`).

    Parameters
    ----------
    entries
        From :func:`~sassi_bench.storage.inventory.inventory`.
    include_referenced
        Also sessions that published bundles use as inputs.
    include_measurements
        Also scans and snapshots taken by commands.
    include_interrupted
        Also sessions of interrupted runs and incomplete sessions.
    include_damaged
        Also damaged sessions (each still needs the option of what else it is).
    reports
        Also report folders.
    older_than_days
        Only entries not modified for this long.
    runs
        The run records (:func:`~sassi_bench.storage.runs.read_runs`).

    Examples
    --------
    >>> clean_candidates([])
    []
    """
    cutoff = (now or datetime.now(UTC)) - timedelta(days=older_than_days)
    options = {
        "include_referenced": include_referenced,
        "include_measurements": include_measurements,
        "include_interrupted": include_interrupted,
        "include_damaged": include_damaged,
        "reports": reports,
    }
    return [e for e in entries if keep_reason(e, cutoff=cutoff, runs=runs, **options) is None]


def remove(entries: Iterable[DataEntry], root: Path) -> int:
    """Delete the entries' folders (and staging folders left empty); bytes freed.

    Each folder is first renamed to a hidden temporary name, so an interrupted removal
    never leaves half a session under its name (the hidden leftover is listed and
    removed by the next clean).
    """
    freed = 0
    for entry in entries:
        if entry.kind == "bundle":  # never, whatever the caller passed
            continue
        trash = temporary_sibling(entry.path)
        os.rename(entry.path, trash)
        shutil.rmtree(trash)
        freed += entry.size_bytes
    staging = root / "staging"
    if staging.is_dir():
        for run in staging.iterdir():
            for folder in (run / "sessions", run):
                if folder.is_dir() and not any(folder.iterdir()):
                    folder.rmdir()
    return freed
