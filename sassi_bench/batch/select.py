"""Which sessions a batch takes: an id pattern, or every pinhole scan under the data root."""

from __future__ import annotations

import fnmatch
import json
import os
from pathlib import Path

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.paths import data_root

__all__ = ["SCAN_PLAN", "select_sessions"]

#: The plan name of a pinhole scan (:func:`sassi_bench.spectra.scan.scan_plan`).
SCAN_PLAN = "pinhole-scan"


def _plan_name(folder: Path) -> str | None:
    """The plan name in ``session.json``; None when the file cannot be read (the task that
    opens the session then reports why, for that session alone)."""
    try:
        return str(json.loads((folder / "session.json").read_bytes())["plan"]["name"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def select_sessions(
    pattern: str | None = None,
    *,
    data: str | os.PathLike[str] | None = None,
) -> list[str]:
    """Session ids under ``<data>/sessions`` for a batch, sorted.

    Parameters
    ----------
    pattern
        Shell pattern on session ids (``scan-*``, ``scan-2026-11-2?``); None takes every
        pinhole scan.
    data
        Data root (see :func:`sassi_bench.paths.data_root`).

    Returns
    -------
    list of str

    Raises
    ------
    ProcedureError
        When nothing matches, or a matching session is readable and not a pinhole scan.

    Examples
    --------
    >>> select_sessions("scan-*", data="/nonexistent")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    ProcedureError: batch sessions: no session matches 'scan-*' under /nonexistent/sessions...
    """
    folder = data_root(data) / "sessions"
    found = sorted(p.name for p in folder.glob("*") if p.is_dir()) if folder.is_dir() else []
    if pattern is None:
        chosen = [s for s in found if _plan_name(folder / s) in (SCAN_PLAN, None)]
    else:
        chosen = [s for s in found if fnmatch.fnmatchcase(s, pattern)]
    if not chosen:
        what = "no pinhole-scan session" if pattern is None else f"no session matches {pattern!r}"
        raise ProcedureError(
            step_error(
                "batch sessions",
                f"{what} under {folder}",
                "check --sessions and the data root (--data / SASSI_BENCH_DATA); "
                "list sessions with: sassi-bench data list",
            )
        )
    others = [s for s in chosen if _plan_name(folder / s) not in (SCAN_PLAN, None)]
    if others:
        raise ProcedureError(
            step_error(
                "batch sessions",
                f"{', '.join(others[:5])} {'is' if len(others) == 1 else 'are'} not a pinhole scan",
                "narrow --sessions to scan sessions (or use --all, which takes only scans)",
            )
        )
    return chosen
