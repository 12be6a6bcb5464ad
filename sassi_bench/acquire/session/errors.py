"""What a raw capture session raises and warns about."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from sassi_bench.errors import SassiBenchError, step_error

__all__ = [
    "FrameDamage",
    "FrameDamagedError",
    "SessionDamagedError",
    "SessionError",
    "SessionIntegrityError",
    "SessionLockedError",
    "SessionWarning",
    "session_error",
]


class SessionError(SassiBenchError, ValueError):
    """A session cannot be created, opened or written as asked."""


class SessionIntegrityError(SessionError):
    """Stored frames or session files no longer match what was recorded."""


@dataclass(frozen=True)
class FrameDamage:
    """A stored frame that is not what its session recorded when it was stored.

    Attributes
    ----------
    session
        The session folder.
    step
        The plan step whose frame it is.
    camera, slot
        Where the frame is stored (``frames.zarr/<camera>``, its slot along the first axis).
    chunk
        The frame's chunk file, relative to the session folder.
    kind
        ``"missing"`` (the chunk file is gone), ``"truncated"`` (shorter than stored),
        ``"unreadable"`` (it does not decode), ``"changed"`` (it decodes to other pixels)
        or ``"mislogged"`` (the frame is intact, one of the hashes its event records is
        damaged: found by a full check only, reads use the frame).
    detail
        What was found, in words.

    Examples
    --------
    >>> damage = FrameDamage(Path("s1"), 3, "spectral", 2, Path("frames.zarr/spectral/c/2/0/0"),
    ...                      "missing", "its chunk file is gone")
    >>> print(damage.describe())  # doctest: +ELLIPSIS
    step 3: the spectral frame (slot 2, frames.zarr/spectral/c/2/0/0) is missing: its chunk ...
    """

    session: Path
    step: int
    camera: str
    slot: int
    chunk: Path
    kind: str
    detail: str

    def describe(self) -> str:
        """The damage in words, naming the step, the frame and its file."""
        return (
            f"step {self.step}: the {self.camera} frame (slot {self.slot}, "
            f"{self.chunk.as_posix()}) is {self.kind}: {self.detail}"
        )


class FrameDamagedError(SessionIntegrityError):
    """A stored frame read back is missing or damaged; ``damage`` says which and how."""

    def __init__(self, message: str, damage: FrameDamage) -> None:
        super().__init__(message)
        self.damage = damage


class SessionDamagedError(SessionIntegrityError):
    """A session's ``session.json``, event log or frame store cannot be read;
    ``condition`` (a :class:`~sassi_bench.acquire.session.salvage.SessionCondition`)
    says what is unreadable and what is left."""

    def __init__(self, message: str, condition: object) -> None:
        super().__init__(message)
        self.condition = condition


class SessionLockedError(SessionError):
    """Another process (or Session object) is writing the session."""


class SessionWarning(UserWarning):
    """Something recoverable was found in a session (e.g. a torn last event line)."""


def session_error(
    step: str, cause: str, fix: str, kind: type[SessionError] = SessionError
) -> SessionError:
    """A session error of class ``kind`` whose message names the step, the cause and the fix.

    Examples
    --------
    >>> print(session_error("session open", "no session at x", "check the id"))
    session open: no session at x. Fix: check the id
    """
    return kind(step_error(step, cause, fix))
