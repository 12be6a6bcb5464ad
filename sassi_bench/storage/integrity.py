"""Whether the sessions under the data root are whole: a quick look for listings, a full
check on demand (``sassi-bench data list`` and ``data verify``).

The quick look (:func:`session_damage`) opens the session (its header and event log must
read) and looks at each logged frame's chunk file without reading it: one gone, or of
another size than stored, is damage; so is what the last full check found, as long as
those frames are still the ones it checked. The full check (:func:`verify_session`) reads
every frame against its checksum and SHA-256 and records what it found in the session's
``verify.json``. A session whose header or log does not read is checked as far as its log
goes (:func:`~sassi_bench.acquire.session.salvage.check_logged_frames`).

Examples
--------
>>> import tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> _ = (folder / "events.jsonl").write_text("")
>>> session_damage(folder)
'session.json is missing; frames.zarr/zarr.json is missing'
>>> session_damage(Path("/nonexistent")) is None  # not a session at all
True
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from sassi_bench.acquire.session import (
    FrameDamage,
    Session,
    SessionDamagedError,
    SessionError,
    SessionWarning,
)
from sassi_bench.acquire.session.salvage import check_logged_frames, examine

#: The parts of a session folder: a folder with none of them is no session.
SESSION_PARTS = ("session.json", "events.jsonl", "frames.zarr")

__all__ = ["SESSION_PARTS", "VerifyResult", "open_quietly", "session_damage", "verify_session"]


def open_quietly(folder: Path) -> Session:
    """Open the session in ``folder`` without warnings (a torn last event line is no
    damage: the capture takes that step again)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SessionWarning)
        return Session.open(folder)


def _steps(damages: list[FrameDamage] | list[dict]) -> str:
    steps = sorted({d.step if isinstance(d, FrameDamage) else d["step"] for d in damages})
    shown = ", ".join(str(s) for s in steps[:4]) + (" ..." if len(steps) > 4 else "")
    return f"step{'s' if len(steps) > 1 else ''} {shown}"


def session_damage(folder: Path) -> str | None:
    """What is wrong with the session in ``folder`` at a glance, or None.

    Reads the header and the event log, and looks at every logged frame's chunk file
    (``stat``, no read), and at the last full check's record.

    Parameters
    ----------
    folder
        A session folder.

    Returns
    -------
    str or None
        In words: what does not read, or which frames are missing or damaged; None also
        for a folder with no part of a session (no ``session.json``, event log or frames).
    """
    if not any((folder / part).exists() for part in SESSION_PARTS):
        return None
    try:
        session = open_quietly(folder)
    except SessionDamagedError as exc:
        return exc.condition.unreadable()
    except SessionError:
        return examine(folder).unreadable() or "it cannot be opened"
    quick = session.find_damage(thorough=False)
    if quick:
        kinds = ", ".join(sorted({d.kind for d in quick}))
        return f"{len(quick)} frame{'s' if len(quick) > 1 else ''} {kinds} ({_steps(quick)})"
    last = session.last_verification()
    if last and last["damaged"]:
        kinds = ", ".join(sorted({d["kind"] for d in last["damaged"]}))
        n = len(last["damaged"])
        return (
            f"{n} frame{'s' if n > 1 else ''} {kinds} ({_steps(last['damaged'])}; "
            f"found by the check of {last['checked']})"
        )
    return None


@dataclass
class VerifyResult:
    """The full check of one session.

    Attributes
    ----------
    folder
        The session folder.
    checked
        Frames read and checked.
    damages
        One line per frame found missing or damaged.
    unreadable
        What of the header, log or frame store does not read (None: they read).
    salvage
        For an unreadable session: what its frames and log still hold.
    found
        The damaged frames of a session that opens (for :meth:`Session.set_aside`).
    """

    folder: Path
    checked: int = 0
    damages: list[str] = field(default_factory=list)
    unreadable: str | None = None
    salvage: str | None = None
    found: list[FrameDamage] = field(default_factory=list)

    @property
    def whole(self) -> bool:
        """Whether everything read and every frame checked out."""
        return self.unreadable is None and not self.damages


def verify_session(folder: Path, on_frame: Callable[[int], None] | None = None) -> VerifyResult:
    """Read every frame of the session in ``folder`` and check it against its event; keep
    the outcome in the session's ``verify.json`` (when the session opens).

    Parameters
    ----------
    folder
        A session folder.
    on_frame
        Called with each step once its frame is checked (a progress bar).

    Returns
    -------
    VerifyResult
    """
    result = VerifyResult(folder)
    try:
        session = open_quietly(folder)
    except SessionError as exc:
        condition = exc.condition if isinstance(exc, SessionDamagedError) else examine(folder)
        result.unreadable = condition.unreadable() or str(exc)
        result.salvage = condition.salvage()
        try:
            result.checked, result.damages = check_logged_frames(folder, on_frame)
        except SessionError as deeper:
            result.damages = [str(deeper).split(". Fix: ")[0]]
        return result
    result.found = session.find_damage(on_frame=on_frame)
    result.checked = len(session.completed)
    result.damages = [d.describe() for d in result.found]
    session.record_verification(result.found)
    return result
