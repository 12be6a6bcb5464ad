"""The history of calibration health checks: one SQLite database in the data root.

``<data root>/health/checks.sqlite`` keeps one row per check (rig, bundle version and
hash, time, figures, verdict, the per-part verdicts and the shift map as JSON). Several
processes may append at once: each append is one ``BEGIN IMMEDIATE`` transaction on its
own connection in write-ahead-log mode, retried while another writer holds the lock.
Write-ahead logging needs a local filesystem (not a network share). ``sassi-bench data
clean`` never removes the database.
"""

from __future__ import annotations

import json
import os
import sqlite3
import time
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.paths import data_root, shared_mode

__all__ = ["COLUMNS", "HealthHistory", "history_path"]

#: The figure and bookkeeping columns of a row, in order (besides ``id``).
COLUMNS = (
    "checked_utc",
    "rig",
    "rig_sha256",
    "bundle_version",
    "bundle_sha256",
    "light",
    "frames",
    "pinholes",
    "capture_s",
    "processing_s",
    "shift_x_mean_px",
    "shift_x_max_px",
    "shift_y_mean_px",
    "shift_y_max_px",
    "wavelength_rms_nm",
    "wavelength_max_nm",
    "tolerance_px",
    "tolerance_nm",
    "verdict",
    "parts_json",
    "map_json",
    "software",
    "session_id",
)

_SCHEMA = """
CREATE TABLE IF NOT EXISTS checks (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  checked_utc TEXT NOT NULL, rig TEXT NOT NULL, rig_sha256 TEXT NOT NULL,
  bundle_version TEXT NOT NULL, bundle_sha256 TEXT NOT NULL,
  light TEXT NOT NULL, frames INTEGER NOT NULL, pinholes INTEGER NOT NULL,
  capture_s REAL NOT NULL, processing_s REAL NOT NULL,
  shift_x_mean_px REAL, shift_x_max_px REAL, shift_y_mean_px REAL, shift_y_max_px REAL,
  wavelength_rms_nm REAL, wavelength_max_nm REAL,
  tolerance_px REAL NOT NULL, tolerance_nm REAL NOT NULL,
  verdict TEXT NOT NULL CHECK (verdict IN ('holds', 'recalibrate')),
  parts_json TEXT NOT NULL, map_json TEXT, software TEXT, session_id TEXT);
CREATE INDEX IF NOT EXISTS checks_rig_time ON checks (rig, checked_utc);
"""
_VERSION = 1
_ATTEMPTS = 60


def history_path(data: str | os.PathLike[str] | None = None) -> Path:
    """Where the health-check database lives under a data root.

    Examples
    --------
    >>> history_path("/lab/data").as_posix()
    '/lab/data/health/checks.sqlite'
    """
    return data_root(data) / "health" / "checks.sqlite"


class HealthHistory:
    """Append-only history of health checks.

    Parameters
    ----------
    path
        The SQLite file (created with its folder on first use).

    Examples
    --------
    >>> import tempfile
    >>> history = HealthHistory(Path(tempfile.mkdtemp()) / "checks.sqlite")
    >>> row = {c: 0 for c in COLUMNS} | {"rig": "sim", "verdict": "holds", "parts_json": "{}"}
    >>> history.append(row)
    1
    >>> [r["rig"] for r in history.rows()]
    ['sim']
    """

    def __init__(self, path: str | os.PathLike[str]) -> None:
        self.path = Path(path)

    def _connect(self) -> sqlite3.Connection:
        new = not self.path.exists()
        if new:
            self.path.parent.mkdir(parents=True, exist_ok=True, mode=shared_mode(directory=True))
        connection = sqlite3.connect(self.path, timeout=30.0, isolation_level=None)
        connection.row_factory = sqlite3.Row
        connection.execute("PRAGMA busy_timeout=30000")
        if new:
            os.chmod(self.path, shared_mode(directory=False))
        return connection

    def _retry(self, work):
        """Run ``work(connection)`` in one immediate transaction, retried while locked."""
        for attempt in range(_ATTEMPTS):
            connection = self._connect()
            try:
                connection.execute("PRAGMA journal_mode=WAL")
                connection.execute("BEGIN IMMEDIATE")
                try:
                    result = work(connection)
                    connection.execute("COMMIT")
                    return result
                except BaseException:
                    connection.execute("ROLLBACK")
                    raise
            except sqlite3.OperationalError as exc:
                if "locked" not in str(exc) and "busy" not in str(exc):
                    raise ProcedureError(
                        step_error(
                            "health history",
                            f"{self.path} cannot be written ({exc})",
                            "check the data root is a local, writable folder",
                        )
                    ) from exc
                time.sleep(min(0.05 * (attempt + 1), 1.0))
            finally:
                connection.close()
        raise ProcedureError(
            step_error(
                "health history",
                f"{self.path} stayed locked by another writer",
                "re-run the check when the other check has finished",
            )
        )

    @staticmethod
    def _ensure(connection: sqlite3.Connection) -> None:
        if connection.execute("PRAGMA user_version").fetchone()[0] < _VERSION:
            for statement in filter(str.strip, _SCHEMA.split(";")):
                connection.execute(statement)
            connection.execute(f"PRAGMA user_version = {_VERSION}")

    def append(self, record: Mapping[str, Any]) -> int:
        """Append one check; returns its row id.

        ``record`` holds every name of :data:`COLUMNS`; mappings and lists (the parts and
        the map) may be given as they are and are stored as JSON.
        """
        missing = [c for c in COLUMNS if c not in record]
        if missing:
            raise ProcedureError(
                step_error(
                    "health history",
                    f"the record has no {', '.join(missing)}",
                    "pass every column of COLUMNS",
                )
            )
        values = [
            json.dumps(record[c]) if isinstance(record[c], (dict, list)) else record[c]
            for c in COLUMNS
        ]

        def insert(connection):
            self._ensure(connection)
            cursor = connection.execute(
                f"INSERT INTO checks ({', '.join(COLUMNS)}) "
                f"VALUES ({', '.join('?' * len(COLUMNS))})",
                values,
            )
            return int(cursor.lastrowid)

        return self._retry(insert)

    def rows(self, rig: str | None = None, since: str | None = None) -> list[dict[str, Any]]:
        """Every check (oldest first), of one rig and from a time (ISO 8601) on if given."""
        if not self.path.exists():
            return []
        connection = self._connect()
        try:
            if connection.execute("PRAGMA user_version").fetchone()[0] < _VERSION:
                return []
            query, args = "SELECT * FROM checks WHERE 1=1", []
            if rig is not None:
                query, args = query + " AND rig = ?", [*args, rig]
            if since is not None:
                query, args = query + " AND checked_utc >= ?", [*args, since]
            cursor = connection.execute(query + " ORDER BY checked_utc, id", args)
            return [dict(row) for row in cursor.fetchall()]
        finally:
            connection.close()
