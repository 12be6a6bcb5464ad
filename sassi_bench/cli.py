"""The ``sassi-bench`` command line: a thin layer over the package.

Each command group lives beside the code it drives and registers itself here through a
``register(subparsers)`` function, so this module only assembles the parser.

Examples
--------
>>> main(["rig", "show", "--rig", "sim"])  # doctest: +SKIP
"""

from __future__ import annotations

import argparse
import shlex
import sys
from collections.abc import Sequence
from datetime import UTC, datetime

from sassi_bench import __version__
from sassi_bench.errors import SassiBenchError

__all__ = ["build_parser", "main", "new_session", "resume_command"]

PROG = "sassi-bench"


def build_parser() -> argparse.ArgumentParser:
    """Assemble the full argument parser from every command group."""
    from sassi_bench.batch import cli as batch_cli
    from sassi_bench.bundle import cli as bundle_cli
    from sassi_bench.export import cli as export_cli
    from sassi_bench.rig import cli as rig_cli
    from sassi_bench.spectra import cli as scan_cli
    from sassi_bench.storage import cli as data_cli
    from sassi_bench.validate import cli as validate_cli
    from sassi_bench.workflows import cli as workflow_cli

    parser = argparse.ArgumentParser(
        prog=PROG,
        description=(
            "Calibrate a SASSI hyperspectral camera, on real hardware or the virtual bench."
        ),
    )
    parser.add_argument("--version", action="version", version=f"sassi-bench {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    rig_cli.register(sub)
    workflow_cli.register(sub)
    scan_cli.register(sub)
    bundle_cli.register(sub)
    export_cli.register(sub)
    validate_cli.register(sub)
    data_cli.register(sub)
    batch_cli.register(sub)
    return parser


def new_session(args: argparse.Namespace, dest: str, prefix: str) -> str:
    """The session id option ``dest`` of a command that captures: the one given (checked
    before anything is captured), else a new ``<prefix>-<UTC time>``, stored back in
    ``args`` so an interrupted run can be resumed with it.

    A command that captures registers its session options as ``resume_options`` (see
    :func:`resume_command`).

    Examples
    --------
    >>> args = argparse.Namespace(session=None)
    >>> new_session(args, "session", "scan").startswith("scan-"), args.session[:5]
    (True, 'scan-')
    """
    from sassi_bench.acquire.session import check_session_id

    value = getattr(args, dest)
    if value is None:
        value = f"{prefix}-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
        setattr(args, dest, value)
    check_session_id(value)
    return value


def check_output_folder(step: str, out: str) -> None:
    """Refuse an output folder (``--out``) that is a file, before anything is captured.

    Examples
    --------
    >>> check_output_folder("validate snapshot", "a-new-folder")
    """
    from pathlib import Path

    from sassi_bench.errors import ProcedureError, step_error

    if Path(out).exists() and not Path(out).is_dir():
        raise ProcedureError(step_error(step, f"--out {out} is a file", "give a folder"))


def resume_command(argv: Sequence[str], args: argparse.Namespace) -> str | None:
    """The command line that resumes an interrupted run: the one that started it, with the
    session options (``args.resume_options``: (dest, flag) pairs) set to the sessions the
    run used. None for a command that keeps nothing to resume.

    Examples
    --------
    >>> args = argparse.Namespace(session="full-1", resume_options=(("session", "--session"),))
    >>> resume_command(["calibrate", "--rig", "sim", "--quiet"], args)
    'sassi-bench calibrate --rig sim --quiet --session full-1'
    >>> resume_command(["calibrate", "--session=old", "--quiet"], args)
    'sassi-bench calibrate --quiet --session full-1'
    """
    options = getattr(args, "resume_options", ())
    if not options:
        return None
    flags = {flag for _, flag in options}
    kept: list[str] = []
    skip = False
    for token in argv:
        if skip:
            skip = False
        elif token in flags:
            skip = True
        elif not token.startswith(tuple(f"{flag}=" for flag in flags)):
            kept.append(token)
    for dest, flag in options:
        value = getattr(args, dest, None)
        if value is not None:
            kept += [flag, str(value)]
    return shlex.join([PROG, *kept])


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
