"""What a raw capture session raises and warns about."""

from __future__ import annotations

from sassi_bench.errors import SassiBenchError, step_error

__all__ = [
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
