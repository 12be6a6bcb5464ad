"""Which sessions a batch takes: an id pattern, or every pinhole scan under the data root
(of one scene, for a batch that needs one: ``batch validate`` scores ColorChecker scans
only, never a white reference or a natural scene)."""

from __future__ import annotations

import fnmatch
import json
import os
from pathlib import Path

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.paths import data_root

__all__ = ["SCAN_PLAN", "scan_scenes", "select_sessions"]

#: The plan name of a pinhole scan (:func:`sassi_bench.acquire.scan_plans.scan_plan`).
SCAN_PLAN = "pinhole-scan"


def _plan(folder: Path) -> dict | None:
    """The plan in ``session.json``; None when the file cannot be read (the task that
    opens the session then reports why, for that session alone)."""
    try:
        plan = json.loads((folder / "session.json").read_bytes())["plan"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return plan if isinstance(plan, dict) else None


def _plan_name(folder: Path) -> str | None:
    plan = _plan(folder)
    return None if plan is None else str(plan.get("name"))


def _scene(folder: Path) -> str | None:
    plan = _plan(folder)
    scene = None if plan is None else (plan.get("parameters") or {}).get("scene")
    return None if scene is None else str(scene)


def scan_scenes(data: str | os.PathLike[str] | None = None) -> dict[str, str | None]:
    """Every pinhole-scan session under ``<data>/sessions`` and the scene it scanned.

    Examples
    --------
    >>> scan_scenes("/nonexistent")
    {}
    """
    folder = data_root(data) / "sessions"
    if not folder.is_dir():
        return {}
    return {
        p.name: _scene(p)
        for p in sorted(folder.glob("*"))
        if p.is_dir() and _plan_name(p) == SCAN_PLAN
    }


def select_sessions(
    pattern: str | None = None,
    *,
    data: str | os.PathLike[str] | None = None,
    scene: str | None = None,
) -> list[str]:
    """Session ids under ``<data>/sessions`` for a batch, sorted.

    Parameters
    ----------
    pattern
        Shell pattern on session ids (``scan-*``, ``scan-2026-11-2?``); None takes every
        pinhole scan (of ``scene``).
    data
        Data root (see :func:`sassi_bench.paths.data_root`).
    scene
        Only scans of this scene (``colorchecker`` for a validation); a session the
        pattern matches that scanned another scene is refused.

    Returns
    -------
    list of str

    Raises
    ------
    ProcedureError
        When nothing matches, or a matching session is readable and not a pinhole scan
        (of ``scene``).

    Examples
    --------
    >>> select_sessions("scan-*", data="/nonexistent")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    ProcedureError: batch sessions: no session matches 'scan-*' under /nonexistent/sessions...
    """
    folder = data_root(data) / "sessions"
    found = sorted(p.name for p in folder.glob("*") if p.is_dir()) if folder.is_dir() else []

    def wanted(session: str) -> bool:
        name = _plan_name(folder / session)
        if name is None:
            return True
        return name == SCAN_PLAN and (scene is None or _scene(folder / session) == scene)

    if pattern is None:
        chosen = [s for s in found if wanted(s)]
    else:
        chosen = [s for s in found if fnmatch.fnmatchcase(s, pattern)]
    kind = "pinhole scan" if scene is None else f"pinhole scan of the {scene} scene"
    if not chosen:
        what = f"no {kind} session" if pattern is None else f"no session matches {pattern!r}"
        raise ProcedureError(
            step_error(
                "batch sessions",
                f"{what} under {folder}",
                "check --sessions and the data root (--data / SASSI_BENCH_DATA); "
                "list sessions with: sassi-bench data list",
            )
        )
    others = [s for s in chosen if not wanted(s)]
    if others:
        listed = ", ".join(
            s + ("" if _scene(folder / s) is None else f" ({_scene(folder / s)})")
            for s in others[:5]
        )
        raise ProcedureError(
            step_error(
                "batch sessions",
                f"{listed} {'is' if len(others) == 1 else 'are'} not a {kind}",
                f"narrow --sessions to {kind} sessions (or use --all, which takes only those)",
            )
        )
    return chosen
