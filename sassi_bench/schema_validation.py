"""Validating YAML/JSON documents against a JSON Schema with readable errors.

Rig descriptions and procedure files are checked by JSON Schemas shipped in the
package; errors name the offending key as a dotted path and suggest the closest valid
key for typos.
"""

from __future__ import annotations

import difflib
from typing import Any

import jsonschema

from sassi_bench.errors import ConfigError

__all__ = ["validate_against_schema"]


def _allowed_keys(schema: dict[str, Any], path: list[str | int]) -> list[str]:
    node = schema
    for part in path:
        node = node.get("properties", {}).get(str(part), {})
    return list(node.get("properties", {}))


def _format_error(error: jsonschema.ValidationError, schema: dict[str, Any]) -> str:
    where = ".".join(str(p) for p in error.absolute_path) or "(top level)"
    if error.validator == "additionalProperties":
        allowed = _allowed_keys(schema, list(error.absolute_path))
        extras = sorted(set(error.instance) - set(allowed))
        hints = []
        for key in extras:
            close = difflib.get_close_matches(key, allowed, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            hints.append(f"{key!r}{hint}")
        prefix = "" if where == "(top level)" else f"{where}."
        return (
            f"{prefix}{extras[0] if extras else '?'}: unknown key {', '.join(hints)}. "
            f"Fix: remove it or use one of {', '.join(allowed)}"
        )
    if error.validator == "required":
        return f"{where}: {error.message}. Fix: add the missing key"
    return f"{where}: {error.message}"


def validate_against_schema(data: Any, schema: dict[str, Any], what: str) -> None:
    """Raise :class:`ConfigError` listing (up to five) schema violations of ``data``.

    Parameters
    ----------
    data
        The parsed document (JSON-compatible).
    schema
        A JSON Schema (draft 2020-12).
    what
        Names the document in the message, e.g. ``"rig description sim.yaml"``.

    Examples
    --------
    >>> schema = {"type": "object", "properties": {"width": {"type": "integer"}},
    ...           "additionalProperties": False}
    >>> validate_against_schema({"widht": 3}, schema, "demo")
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: demo is invalid:
      widht: unknown key 'widht' (did you mean 'width'?). Fix: remove it or use one of width
    """
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(data), key=lambda e: list(map(str, e.absolute_path)))
    if errors:
        lines = [_format_error(e, schema) for e in errors[:5]]
        raise ConfigError(f"{what} is invalid:\n  " + "\n  ".join(lines))
