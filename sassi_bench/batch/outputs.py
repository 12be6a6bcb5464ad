"""Batch outputs on a shared store: written atomically, recognised as finished by hash.

Every output ``<out>/<session>.<suffix>`` gets a record ``<out>/<session>.<suffix>.json``:
the SHA-256 of the output file and of the inputs it was made from (the session's content,
the bundle's manifest, the options). Both are written to a temporary name in the same
folder and renamed into place (atomic on POSIX file systems, NFS included), the output
before its record, so a record names only a complete file. A re-run skips a session
whose output still has its recorded hash and inputs; an output without a record (the run
died between the two renames) is made again.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from sassi_bench._shared.atomic import atomic_path, atomic_write_text
from sassi_bench.bundle.integrity import sha256_file
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["finished", "record_path", "write_atomic"]


def record_path(output: Path) -> Path:
    """The record beside an output: ``cube.nc`` -> ``cube.nc.json``.

    Parameters
    ----------
    output
        An output file.

    Returns
    -------
    pathlib.Path
        Its record's path.

    Examples
    --------
    >>> record_path(Path("out/s1.nc")).as_posix()
    'out/s1.nc.json'
    """
    return output.with_name(output.name + ".json")


def finished(output: Path, inputs: Mapping[str, Any]) -> bool:
    """True if ``output`` is complete and was made from ``inputs``.

    Parameters
    ----------
    output
        The output file.
    inputs
        What it should have been made from (as given to :func:`write_atomic`).

    Returns
    -------
    bool
        False if the output or its record is missing, unreadable or does not match the
        output's hash (the output is made again).

    Raises
    ------
    ProcedureError
        If the output is complete but was made from other inputs: it is not overwritten.

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "s.txt"
    >>> write_atomic(out, lambda p: p.write_text("cube"), {"session": "ab"})
    >>> finished(out, {"session": "ab"}), finished(out.with_name("t.txt"), {})
    (True, False)
    """
    record = record_path(output)
    if not (output.is_file() and record.is_file()):
        return False
    try:
        saved = json.loads(record.read_bytes())
    except ValueError:
        return False
    if saved.get("sha256") != sha256_file(output):
        return False  # damaged or replaced since: made again
    if saved.get("inputs") != json.loads(json.dumps(dict(inputs))):
        raise ProcedureError(
            step_error(
                "batch output",
                f"{output} exists and was made from other inputs (another bundle, session "
                "content or options)",
                "write this batch to another --out folder, or remove the old output",
            )
        )
    return True


def write_atomic(output: Path, write: Callable[[Path], Any], inputs: Mapping[str, Any]) -> None:
    """``write(temporary_path)``, then rename into ``output`` and record its hash and inputs.

    A reader never sees a partial output; a crash leaves at most a hidden temporary file.

    Parameters
    ----------
    output
        The output file; its folder is created if needed. An existing one is replaced.
    write
        Called with a temporary path beside ``output`` (not yet created) to write into.
    inputs
        What the output is made from (JSON-compatible), kept in its record.

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "s.txt"
    >>> write_atomic(out, lambda p: p.write_text("cube"), {"session": "ab"})
    >>> sorted(p.name for p in out.parent.iterdir())
    ['s.txt', 's.txt.json']
    """
    output.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(output, overwrite=True) as temporary:
        write(temporary)
    body = {"output": output.name, "sha256": sha256_file(output), "inputs": dict(inputs)}
    atomic_write_text(record_path(output), json.dumps(body, indent=1) + "\n", overwrite=True)
