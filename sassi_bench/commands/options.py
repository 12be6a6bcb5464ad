"""What every command group shares: the rig, data-root and bundle options, new session ids,
output checks made before anything is captured, the resume line, and check tables.

Examples
--------
>>> import argparse
>>> parser = argparse.ArgumentParser()
>>> add_rig_option(parser); add_bundle_options(parser); add_data_option(parser)
>>> sorted(vars(parser.parse_args(["--bundle", "v0002"])).items())
[('bundle', 'v0002'), ('bundle_rig', None), ('data', None), ('rig', 'sim')]
"""

from __future__ import annotations

import argparse
import contextlib
import shlex
import shutil
import sys
from collections.abc import Iterable, Iterator, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sassi_bench.errors import ProcedureError, step_error

if TYPE_CHECKING:
    from sassi_bench.bundle import CalibrationBundle

__all__ = [
    "PROG",
    "add_bundle_options",
    "add_data_option",
    "add_rig_option",
    "add_simulate_option",
    "bundle_from_args",
    "check_new_files",
    "check_output_file",
    "check_output_folder",
    "holding_rig",
    "latest_problem",
    "load_bundle_ref",
    "new_session",
    "print_checks",
    "program",
    "resume_command",
]

PROG = "sassi-bench"

DATA_HELP = "data root (default: $SASSI_BENCH_DATA, else the checkout's calib_data/)"


def program() -> str:
    """How to run this command line again, as shell words for a printed command.

    ``sassi-bench`` when that name on ``PATH`` is the very program that runs; else the
    path it was started by, made absolute (a virtual environment's ``.venv/bin/sassi-bench``
    is not on ``PATH`` until the environment is activated, and a bare name pasted from a
    printed line would then not be found); ``python -m sassi_bench`` as started so.

    Examples
    --------
    >>> program()  # in a test run, not started as sassi-bench
    'sassi-bench'
    """
    started = Path(sys.argv[0]) if sys.argv and sys.argv[0] else None
    if started is None:
        return PROG
    if started.name == PROG:
        found = shutil.which(PROG)
        if found is not None and Path(found).resolve() == started.resolve():
            return PROG
        return shlex.quote(str(started.absolute()))
    if started.name == "__main__.py" and started.parent.name == "sassi_bench":
        return f"{shlex.quote(sys.executable)} -m sassi_bench"
    return PROG


def add_rig_option(parser: argparse.ArgumentParser, default: str | None = "sim") -> None:
    """``--rig``: a shipped rig name or a rig YAML path.

    Examples
    --------
    >>> parser = argparse.ArgumentParser()
    >>> add_rig_option(parser)
    >>> parser.parse_args([]).rig
    'sim'
    """
    shown = f"default: {default}" if default else "default: see the command"
    parser.add_argument("--rig", default=default, help=f"rig name or YAML path ({shown})")


def add_simulate_option(parser: argparse.ArgumentParser) -> None:
    """``--simulate``: run a ``backend: hardware`` rig's real adapters against the
    simulators of its devices, with the virtual bench behind them.

    Examples
    --------
    >>> parser = argparse.ArgumentParser()
    >>> add_simulate_option(parser)
    >>> parser.parse_args(["--simulate"]).simulate
    True
    """
    parser.add_argument(
        "--simulate",
        action="store_true",
        help="hardware rigs: drive the real adapters against simulated devices "
        "(a virtual display, a serial trigger, camera simulators) and the virtual bench",
    )


def add_data_option(parser: argparse.ArgumentParser) -> None:
    """``--data DIR``: the data root (see :func:`sassi_bench.paths.data_root`).

    Examples
    --------
    >>> parser = argparse.ArgumentParser()
    >>> add_data_option(parser)
    >>> parser.parse_args(["--data", "lab"]).data
    'lab'
    """
    parser.add_argument("--data", metavar="DIR", default=None, help=DATA_HELP)


def add_bundle_options(parser: argparse.ArgumentParser) -> None:
    """``--bundle`` and ``--bundle-rig``, for commands that use a bundle with a rig.

    Examples
    --------
    >>> parser = argparse.ArgumentParser()
    >>> add_bundle_options(parser)
    >>> vars(parser.parse_args(["--bundle", "v0002"]))
    {'bundle': 'v0002', 'bundle_rig': None}
    """
    parser.add_argument(
        "--bundle", help="bundle: a version (latest, v0003, 3; default latest) or a folder"
    )
    parser.add_argument("--bundle-rig", help="rig folder of the bundle (default: the rig's name)")


def load_bundle_ref(ref: str | None, rig: str, data: str | None) -> CalibrationBundle:
    """Load (and verify) the bundle named by a version of ``rig`` or by a folder path (see
    :func:`~sassi_bench.bundle.layout.resolve_bundle_ref`).

    Examples
    --------
    >>> load_bundle_ref("latest", "sim", None).version
    'v0002'
    """
    from sassi_bench.bundle.layout import resolve_bundle_ref
    from sassi_bench.bundle.loader import load

    return load(resolve_bundle_ref(ref, rig=rig, data=data))


def bundle_from_args(
    args: argparse.Namespace,
    rig_name: str,
    *,
    step: str,
    needs: Sequence[str] = (),
    wants: Sequence[str] = (),
) -> CalibrationBundle:
    """Load the bundle ``--bundle``/``--bundle-rig``/``--data`` name for rig ``rig_name``,
    and print which one and why (see :func:`~sassi_bench.bundle.choice.choose_bundle`:
    ``latest`` is the newest bundle with the models the command ``needs``).

    Examples
    --------
    Not run here (it runs a command on a rig and its data)::

        bundle_from_args(args, rig.description.name, step="scan")
        # bundle: sim/v0003 (latest)
    """
    from sassi_bench.bundle.choice import choose_bundle
    from sassi_bench.bundle.loader import load

    choice = choose_bundle(
        args.bundle,
        rig=getattr(args, "bundle_rig", None) or rig_name,
        data=getattr(args, "data", None),
        needs=needs,
        wants=wants,
        step=step,
    )
    print(f"bundle: {choice}", flush=True)
    if args.bundle in (None, "latest", "LATEST"):
        warning = latest_problem(choice.path.parent)  # the rig folder
        if warning is not None:
            print(f"warning: {warning}", flush=True)
    return load(choice.path)


@contextlib.contextmanager
def holding_rig(args: argparse.Namespace) -> Iterator[None]:
    """Hold the rig lock of a command that drives a rig (``args.drives_rig``, set by its
    parser) for the whole command, taken before its start-up work: another procedure
    driving the rig (or, on hardware, one of its devices) is refused at once, before the
    rig is opened, a bundle loaded or anything planned (see
    :mod:`sassi_bench.workflows.rig_lock`). Any other command runs as it is.

    Examples
    --------
    >>> with holding_rig(argparse.Namespace(command="data")):
    ...     pass
    """
    if not getattr(args, "drives_rig", False):
        yield
        return
    from sassi_bench.rig import load_rig_description
    from sassi_bench.workflows.rig_lock import driving

    words = [getattr(args, "command", PROG)]
    words += [
        str(getattr(args, dest))
        for dest in ("calibrate_command", "kind", "rig_command", "snapshot_command",
                     "validate_command", "check_command")
        if getattr(args, dest, None)
    ]  # fmt: skip
    with driving(load_rig_description(args.rig), getattr(args, "data", None), " ".join(words)):
        yield


def new_session(args: argparse.Namespace, dest: str, prefix: str) -> str:
    """The session id option ``dest`` of a command that captures: the one given (checked
    before anything is captured), else a new ``<prefix>-<UTC time>``, stored back in
    ``args`` so an interrupted run can be resumed with it.

    A command that captures registers its session options as ``resume_options`` (see
    :func:`resume_command`); ``args.on_session``, when set (by
    :func:`sassi_bench.commands.main`), is called once the id is fixed.

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
    on_session = getattr(args, "on_session", None)
    if on_session is not None:  # main() records the run, so an interrupted one is found
        on_session(args)
    return value


def check_output_folder(step: str, out: str | None, what: str = "give a folder") -> None:
    """Refuse an output folder (``--out``) that is a file, before anything is captured.

    Examples
    --------
    >>> check_output_folder("validate snapshot", "a-new-folder")
    """
    if out is not None and Path(out).exists() and not Path(out).is_dir():
        raise ProcedureError(step_error(step, f"--out {out} is a file", what))


def check_output_file(step: str, path: str, option: str, suffixes: Sequence[str] = ()) -> None:
    """Refuse an output file that exists or whose folder does not, before anything is
    captured (``suffixes``: the file is written as several, e.g. ENVI's .hdr and .img).

    Examples
    --------
    >>> check_output_file("scan", "cube.nc", "--out")
    >>> check_output_file("scan", "no/such/folder/cube.nc", "--out")
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: scan: --out no/such/folder/cube.nc: the folder ...
    """
    folder = Path(path).resolve().parent
    if not folder.is_dir():
        raise ProcedureError(
            step_error(step, f"{option} {path}: the folder {folder} does not exist", "create it")
        )
    files = [Path(path).with_suffix(s) for s in suffixes] or [Path(path)]
    check_new_files(step, files, f"{option} name")


def check_new_files(step: str, files: Iterable[str | Path], where: str = "--out folder") -> None:
    """Refuse to write where a result already is: results are never replaced.

    Examples
    --------
    >>> check_new_files("validate macbeth", ["a-new-folder/macbeth_report.html"])
    """
    taken = [str(f) for f in files if Path(f).exists()]
    if taken:
        more = f" (and {len(taken) - 1} more)" if len(taken) > 1 else ""
        raise ProcedureError(
            step_error(
                step,
                f"{taken[0]}{more} already exists",
                f"give another {where}, or move the earlier result away: results are never "
                "replaced",
            )
        )


def resume_command(argv: Sequence[str], args: argparse.Namespace) -> str | None:
    """The command line that resumes an interrupted run: the one that started it, with the
    session options (``args.resume_options``: (dest, flag) pairs) set to the sessions the
    run used, and the program named as it was started (:func:`program`). None for a
    command that keeps nothing to resume.

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
    return f"{program()} {shlex.join(kept)}"


def print_checks(checks: Iterable[Any], name_width: int = 40) -> None:
    """One line per quality check: PASS/FAIL, name, value, tolerance.

    Examples
    --------
    >>> from sassi_bench.bundle import QualityCheck
    >>> print_checks([QualityCheck.at_most("rms", 0.02, 0.1, "px")], name_width=8)
      PASS  rms          0.0200 <= 0.1 px
    """
    from sassi_bench.bundle.quality import format_tolerance, unit_suffix

    for check in checks:
        mark = "PASS" if check.passed else "FAIL"
        limit = f"{check.comparison} {format_tolerance(check.tolerance)}{unit_suffix(check.unit)}"
        print(f"  {mark}  {check.name:{name_width}s} {check.value:10.4f} {limit}")


def latest_problem(folder: Path) -> str | None:
    """What is wrong with a rig folder's ``LATEST``, with the fix (None: it names a
    version there, or there is none): ``bundle list`` and every command that takes the
    ``latest`` bundle print it as a warning.

    Examples
    --------
    >>> latest_problem(Path("/nonexistent")) is None
    True
    """
    from sassi_bench.bundle.layout import LATEST_NAME, latest_version, versions

    file = folder / LATEST_NAME
    try:
        named = file.read_text("utf-8").strip()
    except FileNotFoundError:
        return None
    except (OSError, UnicodeDecodeError) as exc:
        named, why = None, f"cannot be read ({exc})"
    else:
        why = None if (folder / named).is_dir() else f"names {named!r}, which is not there"
    if why is None or not versions(folder):
        return None
    taken = latest_version(folder)
    return (
        f"{file} {why}; `latest` means {taken} (the highest version here) until it is fixed. "
        f"Fix: restore {named or 'that version'} from a backup or its exported zip "
        f"(`{program()} bundle import ZIP`), or write the version to use into {file}"
    )
