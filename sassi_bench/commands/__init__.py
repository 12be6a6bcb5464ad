"""The ``sassi-bench`` command line: the application tier, one module per command group.

Each module (``rig``, ``calibrate``, ``check``, ``scan``, ``bundle``, ``snapshot``, ``validate``,
``data``, ``batch``) adds its group through ``register(subparsers)`` and holds only argument
handling and printing; the work is done by the library (``workflows`` for procedures that
drive a rig, ``validate`` for scoring, ``bundle``, ``export``, ``storage``, ``batch``).
Options every group shares live in :mod:`sassi_bench.commands.options`. Handlers import the
library inside their functions, so building the parser (``--help``, ``--version``, argument
errors) loads no more than argparse.

Examples
--------
>>> main(["rig", "show", "--rig", "sim"])  # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from sassi_bench.commands import (
    batch,
    bundle,
    calibrate,
    check,
    data,
    rig,
    scan,
    snapshot,
    validate,
)
from sassi_bench.commands.options import PROG, resume_command
from sassi_bench.errors import SassiBenchError
from sassi_bench.provenance import package_version

__all__ = ["PROG", "build_parser", "main"]

#: The command groups in the order ``--help`` lists them.
GROUPS = (rig, calibrate, check, scan, bundle, snapshot, validate, data, batch)


def build_parser() -> argparse.ArgumentParser:
    """The full argument parser: every command group's ``register``.

    Examples
    --------
    >>> build_parser().parse_args(["data", "list"]).data_command
    'list'
    """
    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Calibrate a SASSI hyperspectral camera, on real hardware or the virtual bench."
        ),
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {package_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for group in GROUPS:
        group.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit status.

    A workbench error is printed as one line (exit status 2). Ctrl-C ends a run with
    exit status 130 and, for a command that captures, the command that resumes it (every
    frame already stored is kept).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except SassiBenchError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        resume = resume_command(argv, args)
        if resume is None:
            print("interrupted", file=sys.stderr)
        else:
            print(
                "interrupted; the frames captured so far are kept. Resume with:\n  " + resume,
                file=sys.stderr,
            )
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
