"""What a long command prints last: the commands a lab runs next, each with what it is for.

Examples
--------
>>> print_next([(command("check", {"--rig": "sim", "--data": None}), "a health check now")])
next:
  sassi-bench check --rig sim
      a health check now
"""

from __future__ import annotations

import os
import shlex
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from sassi_bench.commands.options import program

__all__ = ["command", "open_line", "print_next"]


def command(words: str, options: Mapping[str, Any] | None = None) -> str:
    """This program's command ``words`` with ``options``, quoted for a shell.

    An option whose value is None or False is left out, one whose value is True is a
    flag.

    Parameters
    ----------
    words
        The command and subcommand, e.g. ``"calibrate response"``.
    options
        Option -> value, in the order they are printed.

    Returns
    -------
    str

    Examples
    --------
    >>> command("calibrate response", {"--rig": "sim", "--bundle": "v0002",
    ...                                "--data": "/lab data", "--simulate": False})
    "sassi-bench calibrate response --rig sim --bundle v0002 --data '/lab data'"
    """
    argv: list[str] = []
    for option, value in (options or {}).items():
        if value is True:
            argv.append(option)
        elif value is not None and value is not False:
            argv += [option, os.fspath(value) if isinstance(value, os.PathLike) else str(value)]
    return " ".join([program(), words, shlex.join(argv)]).rstrip()


def open_line(path: str | os.PathLike[str]) -> str:
    """``open file:///...``: a page to read, as the address a browser takes.

    Examples
    --------
    >>> open_line("/reports/macbeth_report.html")
    'open file:///reports/macbeth_report.html'
    """
    return f"open {Path(path).resolve().as_uri()}"


def print_next(steps: Sequence[tuple[str, str]]) -> None:
    """Print ``next:`` and each step's command line, with what it is for below it.

    Examples
    --------
    >>> print_next([("sassi-bench check --rig sim", "a health check now")])
    next:
      sassi-bench check --rig sim
          a health check now
    """
    print("next:")
    for line, why in steps:
        print(f"  {line}")
        print(f"      {why}")
