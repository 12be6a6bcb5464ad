"""Procedures as named steps, one table each, one runner (as PypeIt's calibrations run).

Each procedure that drives a rig (:mod:`~sassi_bench.workflows.spectral`,
:mod:`~sassi_bench.workflows.full`, ...) keeps its state in one object (the rig, the
procedure, the session ids, what each step made) and lists its steps in order in a table
``STEPS``: one function a step, taking that state. :func:`run_steps` runs the table's
steps, or those asked for, in the table's order. A step that captures resumes its
session, so running the steps again after an interruption redoes only what is missing;
a notebook runs them one at a time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from typing import TypeVar

from sassi_bench.errors import ConfigError, step_error

__all__ = ["StepTable", "run_steps"]

State = TypeVar("State")
#: A procedure's steps in order: name -> the function that runs it on the procedure's state.
StepTable = Mapping[str, Callable[[State], None]]


def run_steps(
    table: StepTable, state: State, steps: Iterable[str] | None = None, *, procedure: str = ""
) -> State:
    """Run ``steps`` of ``table`` (default: all) on ``state``, in the table's order.

    Parameters
    ----------
    table
        The procedure's steps, in order.
    state
        The procedure's state; each step reads and fills it.
    steps
        The names of the steps to run (any order; they run in the table's).
    procedure
        The procedure's name, for errors.

    Returns
    -------
    State
        ``state``, after the steps.

    Raises
    ------
    ConfigError
        For a step the table does not have.

    Examples
    --------
    >>> done = []
    >>> table = {"capture": lambda s: s.append("capture"), "fit": lambda s: s.append("fit")}
    >>> run_steps(table, done, ["fit", "capture"])
    ['capture', 'fit']
    >>> run_steps(table, [], ["fits"], procedure="spectral calibration")
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: spectral calibration: no step named 'fits'. Fix: ...
    """
    chosen = list(table) if steps is None else list(steps)
    unknown = [name for name in chosen if name not in table]
    if unknown:
        raise ConfigError(
            step_error(
                procedure or "procedure",
                f"no step named {unknown[0]!r}",
                f"choose among {', '.join(table)}",
            )
        )
    for name in table:
        if name in chosen:
            table[name](state)
    return state
