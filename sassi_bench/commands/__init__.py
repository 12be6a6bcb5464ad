"""The ``sassi-bench`` command line: the application tier, one module per command group.

Each module (``rig``, ``align``, ``calibrate``, ``check``, ``scan``, ``bundle``, ``snapshot``,
``validate``, ``data``, ``batch``) adds its group through ``register(subparsers)`` and holds
only argument handling and printing; the work is done by the library (``workflows`` for
procedures that drive a rig, ``validate`` for scoring, ``bundle``, ``export``, ``storage``,
``batch``).
Options every group shares live in :mod:`sassi_bench.commands.options`, the ``next:`` lines
a long command ends with in :mod:`sassi_bench.commands.next_steps`. Handlers import the
library inside their functions, so building the parser (``--help``, ``--version``, argument
errors) loads no more than argparse.

Examples
--------
Not run here (it runs a command on a rig and its data)::

    main(["rig", "show", "--rig", "sim"])
"""

from __future__ import annotations

import argparse
import contextlib
import signal
import sys
from collections.abc import Sequence
from pathlib import Path

from sassi_bench._shared.disk import DISK_FULL_FIX, disk_full_cause, is_disk_full
from sassi_bench.commands import (
    align,
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
from sassi_bench.commands.interrupts import (
    Stopped,
    incomplete_sessions,
    record_end,
    record_start,
    signal_name,
    stop_signals,
)
from sassi_bench.commands.options import PROG, holding_rig, resume_command
from sassi_bench.commands.typos import check_options
from sassi_bench.errors import SassiBenchError
from sassi_bench.paths import data_root

__all__ = ["PROG", "build_parser", "main"]

#: The command groups in the order ``--help`` lists them.
GROUPS = (rig, align, calibrate, check, scan, bundle, snapshot, validate, data, batch)


class _Version(argparse.Action):
    """``--version``: the version is looked up only when asked (it is slow to find)."""

    def __init__(self, option_strings: Sequence[str], dest: str, help: str) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser: argparse.ArgumentParser, *args: object) -> None:
        from sassi_bench.provenance import package_version

        print(f"{PROG} {package_version()}")  # on stdout, as argparse's own action
        parser.exit()


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
    parser.add_argument("--version", action=_Version, help="show the version and exit")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for group in GROUPS:
        group.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit status.

    A workbench error is printed as one line (exit status 2). Ctrl-C, SIGTERM and SIGHUP
    end a run alike (exit status 128 + the signal's number: 130, 143, 129) and, for a
    command that captures, print the command that resumes it (every frame already stored
    is kept); that command is also recorded under the data root from the moment the
    run's session ids are fixed (:mod:`sassi_bench.commands.interrupts`).
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser()
    check_options(parser, argv)  # a mistyped option is named before any positional is judged
    args = parser.parse_args(argv)
    args.argv, args.on_session = argv, record_start
    try:
        with stop_signals(), holding_rig(args):
            status = _run_retaking(args)
    except SassiBenchError as exc:
        _say(f"error: {exc}")
        _ended_on_error(args)
        return 2
    except OSError as exc:
        if not is_disk_full(exc):
            raise
        where = Path(exc.filename) if exc.filename else data_root(getattr(args, "data", None))
        _say(f"error: {args.command}: {disk_full_cause(where)}. Fix: {DISK_FULL_FIX}")
        _ended_on_error(args)
        return 2
    except KeyboardInterrupt as exc:
        signum = exc.signum if isinstance(exc, Stopped) else signal.SIGINT
        how = "Ctrl-C" if signum == signal.SIGINT else signal_name(signum)
        record_end(args, interrupted=how)
        resume = resume_command(argv, args)
        if resume is None:
            _say("interrupted" if signum == signal.SIGINT else f"stopped by {how}")
        else:
            stopped = "interrupted" if signum == signal.SIGINT else f"stopped by {how}"
            _say(f"{stopped}; the frames captured so far are kept. Resume with:\n  {resume}")
        return 128 + int(signum)
    record_end(args)
    return status


#: Damaged frames a capture command sets aside and captures again in one run, at most.
MAX_RETAKES = 50


def _run_retaking(args) -> int:
    """Run the command. A command that captures and meets a missing or damaged frame of
    one of its own sessions (``FrameDamagedError``, raised before anything is computed
    from it) sets that frame aside (kept in the session's ``damaged/``) with any other
    frame of the session whose chunk file is gone or cut short, and runs again: resumed,
    the capture takes them again. Any other command stops on it (the error names the
    frame and the fix)."""
    retaken: set[tuple[str, int]] = set()
    while True:
        try:
            return int(args.func(args) or 0)
        except SassiBenchError as exc:
            damage = getattr(exc, "damage", None)
            if damage is None or not getattr(args, "resume_options", ()):
                raise
            if damage.session.name not in _own_sessions(args):
                raise
            if (str(damage.session), damage.step) in retaken or len(retaken) >= MAX_RETAKES:
                raise
            for kept in _set_aside(damage):
                retaken.add((str(damage.session), kept["step"]))
                where = f" (the damaged file kept as {kept['kept']})" if kept["kept"] else ""
                _say(
                    f"session {damage.session.name!r} step {kept['step']}: {kept['reason']}; "
                    f"set aside{where} and captured again"
                )


def _own_sessions(args) -> set[str]:
    """Names of the session folders this run captures into, as they are on disk now."""
    from sassi_bench.commands.interrupts import run_session_folders

    return {folder.name for folder in run_session_folders(args)}


def _set_aside(damage) -> list[dict]:
    """Set a damaged frame aside, with its session's other frames whose chunk files are
    gone or cut short; the records of what was set aside."""
    from sassi_bench.storage.integrity import open_quietly

    session = open_quietly(damage.session)
    others = [d for d in session.find_damage(thorough=False) if d.step != damage.step]
    return session.set_aside([damage, *others])


def _ended_on_error(args) -> None:
    """After an error: a run that left a session incomplete keeps its record and says how
    to resume; any other run's record goes."""
    left = incomplete_sessions(args) if getattr(args, "resume_options", ()) else []
    if not left:
        record_end(args)
        return
    record_end(args, interrupted="an error")
    resume = resume_command(args.argv, args)
    _say(f"the frames captured so far are kept ({', '.join(left)}). Resume with:\n  {resume}")


def _say(text: str) -> None:
    """Print to stderr; a terminal that is gone (SIGHUP) is no reason to fail."""
    with contextlib.suppress(OSError):
        print(text, file=sys.stderr, flush=True)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
