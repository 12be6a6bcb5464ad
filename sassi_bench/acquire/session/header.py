"""``session.json``: what a session captures, written once when it is created.

It holds the schema name and version, the session id, the creation time (UTC), the rig
description and the plan, each with its SHA-256 (of its canonical JSON), and the software
version. Opening a session checks all of it: a header that no longer matches its own
hashes is an integrity error.
"""

from __future__ import annotations

import json
import re
from datetime import datetime
from pathlib import Path
from typing import Any

from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.session.errors import SessionIntegrityError, session_error
from sassi_bench.provenance import package_version
from sassi_bench.rig.config import RigDescription, rig_dict_sha256

__all__ = [
    "SCHEMA_NAME",
    "SCHEMA_VERSION",
    "SESSION_FILE",
    "check_resumable",
    "check_session_id",
    "default_session_id",
    "is_session_id",
    "new_header",
    "parse_header",
    "utc_stamp",
]

SCHEMA_NAME = "sassi-bench/session"
SCHEMA_VERSION = "1.0"
SESSION_FILE = "session.json"

_ID_RE = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]{0,199}$")
_HEADER_KEYS = ("schema", "version", "id", "created", "rig", "rig_sha256", "plan", "plan_sha256")


def is_session_id(text: object) -> bool:
    """Whether ``text`` is a valid session id (a plain folder name).

    Examples
    --------
    >>> is_session_id("lab-2026-11-22"), is_session_id("../elsewhere")
    (True, False)
    """
    return isinstance(text, str) and _ID_RE.match(text) is not None


def check_session_id(session_id: str) -> None:
    """Refuse a session id that is not a plain folder name (before anything is captured).

    Raises
    ------
    SessionError
        If the id is not 1-200 letters, digits, ``.``, ``_`` or ``-`` starting with a letter
        or digit.

    Examples
    --------
    >>> check_session_id("lab-2026-11-22")
    """
    if not is_session_id(session_id):
        raise session_error(
            "session id",
            f"{session_id!r} is not a valid session id",
            "use 1-200 letters, digits, '.', '_' or '-', starting with a letter or digit",
        )


def default_session_id(plan_name: str, now: datetime) -> str:
    """``<UTC time>-<plan name>``, the plan name reduced to id characters.

    Examples
    --------
    >>> from datetime import UTC, datetime
    >>> default_session_id("gray 532", datetime(2025, 1, 1, 12, tzinfo=UTC))
    '20250101T120000Z-gray-532'
    """
    safe_name = re.sub(r"[^A-Za-z0-9._-]+", "-", plan_name).strip("-.") or "plan"
    return f"{now:%Y%m%dT%H%M%SZ}-{safe_name}"[:200]


def utc_stamp(moment: datetime) -> str:
    """A UTC time as ISO 8601 with milliseconds and a ``Z``, as sessions record times.

    Examples
    --------
    >>> from datetime import UTC, datetime
    >>> utc_stamp(datetime(2025, 1, 1, 12, tzinfo=UTC))
    '2025-01-01T12:00:00.000Z'
    """
    return moment.isoformat(timespec="milliseconds").replace("+00:00", "Z")


def new_header(
    session_id: str, rig_description: RigDescription, plan: Plan, now: datetime
) -> tuple[dict[str, Any], bytes]:
    """The header of a new session and its file bytes (indented, sorted keys, UTF-8).

    Examples
    --------
    >>> from datetime import UTC, datetime
    >>> from sassi_bench.acquire.plan import Step
    >>> from sassi_bench.rig import load_rig_description
    >>> plan = Plan("dark", [Step("spectral", "off", 0.1, {"kind": "blank"})])
    >>> header, raw = new_header("d", load_rig_description("sim"), plan,
    ...                          datetime(2025, 1, 1, tzinfo=UTC))
    >>> header["created"], parse_header(raw, Path("session.json"))["id"]
    ('2025-01-01T00:00:00.000Z', 'd')
    """
    header = {
        "schema": SCHEMA_NAME,
        "version": SCHEMA_VERSION,
        "id": session_id,
        "created": utc_stamp(now),
        "rig": rig_description.to_dict(),
        "rig_sha256": rig_description.sha256(),
        "plan": plan.to_dict(),
        "plan_sha256": plan.sha256(),
        "software": {"sassi_bench": package_version()},
    }
    return header, (json.dumps(header, indent=2, sort_keys=True) + "\n").encode("utf-8")


def parse_header(raw: bytes, file: Path) -> dict[str, Any]:
    """Parse and check the bytes of ``session.json`` (``file`` names it in errors).

    Raises
    ------
    SessionIntegrityError
        If it is not JSON, not a session header, lacks keys, or its stored plan or rig no
        longer matches its recorded SHA-256 (the file is damaged).
    SessionError
        If it has another major version.
    """
    fix = "restore the session folder from a backup"
    damaged = SessionIntegrityError
    try:
        header = json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError) as exc:
        raise session_error("session open", f"{file} is not JSON ({exc})", fix, damaged) from exc
    if not isinstance(header, dict) or header.get("schema") != SCHEMA_NAME:
        raise session_error("session open", f"{file} is not a {SCHEMA_NAME} file", fix, damaged)
    missing = [key for key in _HEADER_KEYS if key not in header]
    if missing:
        raise session_error("session open", f"{file} lacks {', '.join(missing)}", fix, damaged)
    major = str(header["version"]).split(".")[0]
    if major != SCHEMA_VERSION.split(".")[0]:
        raise session_error(
            "session open",
            f"{file} has schema version {header['version']}, this software reads "
            f"{SCHEMA_VERSION.split('.')[0]}.x",
            "upgrade sassi_bench",
        )
    try:
        plan = Plan.from_dict(header["plan"])
    except ValueError as exc:  # a PlanError: the stored plan is not a plan
        raise session_error("session open", f"{file}: {exc}", fix, damaged) from exc
    if (
        plan.sha256() != header["plan_sha256"]
        or rig_dict_sha256(header["rig"]) != header["rig_sha256"]
    ):
        raise session_error(
            "session open",
            f"{file}: the stored plan or rig does not match its recorded sha256",
            fix,
            SessionIntegrityError,
        )
    return header


def check_resumable(header: dict[str, Any], rig_description: RigDescription, plan: Plan) -> None:
    """Refuse to resume a session for another plan or rig than the one it was created for.

    Raises
    ------
    SessionError
        Naming both plans (or rigs) and their hashes.
    """
    session_id, plan_sha256, rig_sha256 = header["id"], header["plan_sha256"], header["rig_sha256"]
    if plan_sha256 != plan.sha256():
        raise session_error(
            "session resume",
            f"session {session_id!r} was created for plan {header['plan'].get('name')!r} "
            f"(sha256 {plan_sha256[:12]}), not for plan {plan.name!r} "
            f"(sha256 {plan.sha256()[:12]})",
            "give the new plan another session id, or resume with the settings the session "
            "was captured with (its session.json holds them)",
        )
    if rig_sha256 != rig_description.sha256():
        raise session_error(
            "session resume",
            f"session {session_id!r} was captured on rig {header['rig'].get('name')!r} "
            f"(sha256 {rig_sha256[:12]}), which differs from rig "
            f"{rig_description.name!r} (sha256 {rig_description.sha256()[:12]})",
            "open the rig described in the session's session.json, or pick another session_id",
        )
