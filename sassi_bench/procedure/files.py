"""Procedure files: the lab's editable parameters and acceptance tolerances.

A procedure is a YAML file in ``procedures/`` (or anywhere, given by path), checked
against a JSON Schema shipped beside this module (``schemas/<procedure>.schema.json``).
"""

from __future__ import annotations

import json
import os
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from sassi_bench._shared.atomic import atomic_write_text
from sassi_bench._shared.yaml_io import load_yaml_mapping
from sassi_bench.paths import data_root
from sassi_bench.schema_validation import validate_against_schema

__all__ = ["load_procedure", "save_working_procedure", "with_changes", "working_procedure"]


def load_procedure(kind: str, name_or_path: str | os.PathLike[str] | None = None) -> dict[str, Any]:
    """Load and validate a procedure file.

    Parameters
    ----------
    kind
        Procedure kind, e.g. ``"spectral_calibration"``; names the schema and the default
        file ``procedures/<kind>.yaml``.
    name_or_path
        A path to a YAML file, or None for the shipped default.

    Returns
    -------
    dict
        The validated procedure (JSON-compatible), with ``source`` added.

    Examples
    --------
    >>> proc = load_procedure("spectral_calibration")
    >>> proc["lasers_nm"] is None  # every laser of the rig
    True
    """
    if name_or_path is None:
        file = resources.files("sassi_bench.procedures").joinpath(f"{kind}.yaml")
        source = f"procedures/{kind}.yaml"
    else:
        file = Path(name_or_path)
        source = str(file)
    data = load_yaml_mapping(
        file,
        "procedure",
        label=source,
        missing_fix=f"check the path, or leave the option out for procedures/{kind}.yaml",
        mapping_fix=f"write the procedure as YAML keys (see procedures/{kind}.yaml)",
    )
    data = json.loads(json.dumps(data))
    _validate(kind, data, f"procedure {source}")
    data["source"] = source
    return data


def _validate(kind: str, data: dict[str, Any], where: str) -> None:
    schema_file = resources.files("sassi_bench.procedure").joinpath(
        "schemas", f"{kind}.schema.json"
    )
    schema = json.loads(schema_file.read_text())
    validate_against_schema(data, schema, where)


def with_changes(procedure: dict[str, Any], **changes: Any) -> dict[str, Any]:
    """A copy of a loaded procedure with some top-level keys changed, validated again.

    Notebooks use it for the choices a person makes (which lasers, what tolerance); the
    change is recorded in ``source`` so a published bundle says the procedure was edited.

    Parameters
    ----------
    procedure
        A procedure from :func:`load_procedure` (its ``name`` picks the schema).
    **changes
        New values of top-level keys.

    Returns
    -------
    dict
        The changed, validated procedure; ``source`` names the keys that changed.

    Raises
    ------
    ConfigError
        If the changed procedure breaks its schema.

    Examples
    --------
    >>> proc = with_changes(load_procedure("spectral_calibration"), lasers_nm=[450, 532, 670])
    >>> proc["lasers_nm"], proc["source"]
    ([450, 532, 670], 'procedures/spectral_calibration.yaml (edited: lasers_nm)')
    """
    kind = str(procedure["name"])
    data = json.loads(json.dumps({k: v for k, v in procedure.items() if k != "source"}))
    data.update(json.loads(json.dumps(changes)))
    source = f"{procedure.get('source', kind)} (edited: {', '.join(sorted(changes))})"
    _validate(kind, data, f"procedure {source}")
    data["source"] = source
    return data


def _working_path(kind: str, session_id: str, data) -> Path:
    return data_root(data) / "procedures" / f"{session_id}-{kind}.yaml"


def save_working_procedure(
    procedure: dict[str, Any], session_id: str, data: str | os.PathLike[str] | None = None
) -> Path:
    """Keep the procedure a person settled on for a named session (the notebooks' choices).

    Written to ``<data>/procedures/<session_id>-<kind>.yaml``, where
    :func:`working_procedure` finds it in a later notebook.

    Parameters
    ----------
    procedure
        A loaded (possibly changed) procedure.
    session_id
        The session the procedure is for.
    data
        Data root.

    Returns
    -------
    pathlib.Path
        The YAML file written (replacing an earlier one).

    Examples
    --------
    >>> import tempfile
    >>> tmp = tempfile.mkdtemp()
    >>> proc = with_changes(load_procedure("spectral_calibration"), lasers_nm=[450, 532, 670])
    >>> path = save_working_procedure(proc, "lab", tmp)
    >>> working_procedure("spectral_calibration", "lab", tmp)["lasers_nm"]
    [450, 532, 670]
    """
    kind = str(procedure["name"])
    path = _working_path(kind, session_id, data)
    path.parent.mkdir(parents=True, exist_ok=True)
    body = {k: v for k, v in procedure.items() if k != "source"}
    header = f"# {kind} as settled for session {session_id} (from {procedure.get('source')})\n"
    return atomic_write_text(path, header + yaml.safe_dump(body, sort_keys=False), overwrite=True)


def working_procedure(
    kind: str, session_id: str, data: str | os.PathLike[str] | None = None
) -> dict[str, Any]:
    """The procedure saved for a named session, or the shipped default if none was saved.

    Parameters
    ----------
    kind
        Procedure kind, e.g. ``"spectral_calibration"``.
    session_id
        The session the procedure was saved for (:func:`save_working_procedure`).
    data
        Data root.

    Returns
    -------
    dict
        The validated procedure, with ``source`` naming the file it came from.

    Examples
    --------
    >>> import tempfile
    >>> working_procedure("spectral_calibration", "none-saved", tempfile.mkdtemp())["source"]
    'procedures/spectral_calibration.yaml'
    """
    path = _working_path(kind, session_id, data)
    return load_procedure(kind, path if path.is_file() else None)
