"""Exceptions of the workbench.

Every error raised on bad input names the step, the cause and the fix. The classes
subclass the built-in exception a caller would naturally catch (``ValueError`` for bad
values), so ``except ValueError`` keeps working.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class SassiBenchError(Exception):
    """Base class for every error the workbench raises on purpose."""


class ConfigError(SassiBenchError, ValueError):
    """A rig or procedure description is invalid.

    The message names the offending key as a dotted path (``prism.apex_deg``).
    """


class ProcedureError(SassiBenchError, ValueError):
    """A procedure was given input it cannot work with.

    The message names the step, the cause and the fix (see :func:`step_error`). It is a
    :class:`SassiBenchError`, so the command line prints it as one line without a
    traceback, and a ``ValueError``, so ``except ValueError`` keeps working.

    Examples
    --------
    >>> err = ProcedureError(step_error("scan", "unknown scene 'x'", "use white"))
    >>> isinstance(err, ValueError), str(err)
    (True, "scan: unknown scene 'x'. Fix: use white")
    """


class DeviceError(SassiBenchError, RuntimeError):
    """A device refused a command or is in the wrong state."""


def step_error(step: str, cause: str, fix: str) -> str:
    """Format an error message that names the step, the cause and the fix.

    Parameters
    ----------
    step
        What the workbench was doing, e.g. ``"SLM show"``.
    cause
        What was wrong with the input.
    fix
        What the user should do about it.

    Returns
    -------
    str
        ``"<step>: <cause>. Fix: <fix>"``.

    Examples
    --------
    >>> step_error("SLM show", "pattern has shape (3, 3)", "pass a (400, 640) array")
    'SLM show: pattern has shape (3, 3). Fix: pass a (400, 640) array'
    """
    return f"{step}: {cause}. Fix: {fix}"


def did_you_mean(value: object, choices: Iterable[object]) -> str:
    """A hint naming the choice closest to a mistyped ``value``, or ``""`` if none is close.

    Examples
    --------
    >>> did_you_mean("colorchekcer", ["white", "colorchecker"])
    " (did you mean 'colorchecker'?)"
    >>> did_you_mean("zzz", ["white", "colorchecker"])
    ''
    """
    names = {str(choice): choice for choice in choices}
    close = difflib.get_close_matches(str(value), list(names), n=1)
    return f" (did you mean {names[close[0]]!r}?)" if close else ""
