"""Records of command runs that capture, so an interrupted one can be found and resumed.

A command that captures writes ``<data>/runs/<run>.json`` as soon as its session ids are
fixed (before anything is captured): the command line that resumes it, the session ids
(or id prefixes) it captures into, and its process (pid, host, start time). A run that
ends, successfully or not, removes its record, unless it was interrupted (Ctrl-C,
SIGTERM, SIGHUP) and left a session to finish: the record then says so. A run killed
outright (SIGKILL, a power cut) leaves its record as "running" with a process that no
longer exists, which :attr:`RunRecord.state` reads as interrupted.

``sassi-bench data list`` shows the interrupted runs with their resume commands, and
``data clean`` never removes their sessions.

Examples
--------
>>> import tempfile
>>> data = tempfile.mkdtemp()
>>> path = record_run(data, "scan-1", "sassi-bench scan --session scan-1", ["scan-1"])
>>> [(r.run, r.state) for r in read_runs(data)]
[('scan-1', 'running')]
>>> end_run(data, "scan-1", interrupted="SIGTERM")
>>> [(r.run, r.state, r.note) for r in read_runs(data)]
[('scan-1', 'interrupted', 'SIGTERM')]
>>> end_run(data, "scan-1")
>>> read_runs(data)
[]
"""

from __future__ import annotations

import json
import os
import socket
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from sassi_bench._shared.atomic import atomic_write_text
from sassi_bench.paths import data_root

__all__ = ["RUNS_DIR", "RunRecord", "end_run", "read_runs", "record_run"]

#: Folder of the data root that holds the run records.
RUNS_DIR = "runs"


@dataclass(frozen=True)
class RunRecord:
    """One run of a command that captures.

    Attributes
    ----------
    run
        The run's name: its first session id.
    command
        The command line that resumes it.
    sessions
        Session ids, or id prefixes (``<prefix>-...``), it captures into.
    pid, host, started
        Its process.
    status
        ``"running"`` as written at its start, ``"interrupted"`` once it was stopped.
    note
        How it was stopped (``"SIGTERM"``, ``"Ctrl-C"``...).
    path
        The record file.
    """

    run: str
    command: str
    sessions: tuple[str, ...]
    pid: int
    host: str
    started: str
    status: str
    note: str
    path: Path

    @property
    def state(self) -> str:
        """``"running"`` while its process lives on this host, else ``"interrupted"``
        (a run recorded on another host whose state cannot be known: ``"running"``)."""
        if self.status != "running":
            return self.status
        if self.host != socket.gethostname():
            return "running"
        return "running" if _alive(self.pid) else "interrupted"

    def owns(self, folder_name: str) -> bool:
        """Whether a session or staging folder name is one of this run's.

        Examples
        --------
        >>> record = RunRecord("snap", "", ("snap",), 1, "h", "", "running", "", Path())
        >>> record.owns("snap-f001"), record.owns("snapshot-x")
        (True, False)
        """
        return any(folder_name == s or folder_name.startswith(f"{s}-") for s in self.sessions)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # someone else's process
    return True


def _file(data: str | os.PathLike[str] | None, run: str) -> Path:
    return data_root(data) / RUNS_DIR / f"{run}.json"


def record_run(
    data: str | os.PathLike[str] | None, run: str, command: str, sessions: Iterable[str]
) -> Path:
    """Write (or rewrite) the record of a run that is starting; returns its file."""
    path = _file(data, run)
    path.parent.mkdir(parents=True, exist_ok=True)
    record = {
        "run": run,
        "command": command,
        "sessions": list(sessions),
        "pid": os.getpid(),
        "host": socket.gethostname(),
        "started": datetime.now(UTC).isoformat(timespec="seconds").replace("+00:00", "Z"),
        "status": "running",
        "note": "",
    }
    return atomic_write_text(path, json.dumps(record, indent=1) + "\n", overwrite=True)


def end_run(data: str | os.PathLike[str] | None, run: str, interrupted: str | None = None) -> None:
    """A run ended: remove its record, or, with ``interrupted`` (how it was stopped),
    mark it interrupted."""
    path = _file(data, run)
    if interrupted is None:
        path.unlink(missing_ok=True)
        return
    try:
        record = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError):
        return
    record.update(status="interrupted", note=interrupted)
    atomic_write_text(path, json.dumps(record, indent=1) + "\n", overwrite=True)


def read_runs(data: str | os.PathLike[str] | None = None) -> list[RunRecord]:
    """Every run record under the data root, oldest first (unreadable ones skipped).

    Examples
    --------
    >>> read_runs("/nonexistent")
    []
    """
    folder = data_root(data) / RUNS_DIR
    if not folder.is_dir():
        return []
    found = []
    for path in sorted(folder.glob("*.json")):
        try:
            raw = json.loads(path.read_text("utf-8"))
            found.append(
                RunRecord(
                    str(raw["run"]), str(raw["command"]), tuple(map(str, raw["sessions"])),
                    int(raw["pid"]), str(raw["host"]), str(raw["started"]),
                    str(raw["status"]), str(raw.get("note", "")), path,
                )
            )  # fmt: skip
        except (OSError, ValueError, KeyError, TypeError):
            continue
    return sorted(found, key=lambda r: r.started)
