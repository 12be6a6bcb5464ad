"""Validating YAML/JSON documents against a JSON Schema with readable errors.

Rig descriptions and procedure files are checked by JSON Schemas shipped in the
package; errors name the offending key as a dotted path and suggest the closest valid
key for typos.
"""

from __future__ import annotations

from typing import Any

import jsonschema

from sassi_bench.errors import ConfigError, did_you_mean, step_error

__all__ = ["validate_against_schema"]


def _allowed_keys(schema: dict[str, Any], path: list[str | int]) -> list[str]:
    node = schema
    for part in path:
        node = node.get("properties", {}).get(str(part), {})
    return list(node.get("properties", {}))


def _cause_and_fix(error: jsonschema.ValidationError, schema: dict[str, Any]) -> tuple[str, str]:
    """What is wrong at one place of the document, and what to do about it."""
    where = ".".join(str(p) for p in error.absolute_path)
    if error.validator == "additionalProperties":
        allowed = _allowed_keys(schema, list(error.absolute_path))
        extras = sorted(set(error.instance) - set(allowed))
        hints = [f"{key!r}{did_you_mean(key, allowed)}" for key in extras]
        key = f"{where}.{extras[0]}" if where else (extras[0] if extras else "?")
        return (
            f"{key}: unknown key {', '.join(hints)}",
            f"remove it or use one of {', '.join(allowed)}",
        )
    where = where or "(top level)"
    if error.validator == "required":
        return f"{where}: {error.message}", "add the missing key"
    return f"{where}: {error.message}", f"correct {where}"


def validate_against_schema(data: Any, schema: dict[str, Any], what: str) -> None:
    """Raise :class:`ConfigError` naming (up to five) schema violations of ``data``.

    The message is one line, ``"<what>: <key>: <cause>. Fix: <fix>"``, with the causes
    and fixes of several violations joined by semicolons.

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
    >>> try:
    ...     validate_against_schema({"widht": 3}, schema, "demo")
    ... except ConfigError as exc:
    ...     print(exc)
    demo: widht: unknown key 'widht' (did you mean 'width'?). Fix: remove it or use one of width
    """
    validator = jsonschema.Draft202012Validator(schema)
    errors = sorted(validator.iter_errors(data), key=lambda e: list(map(str, e.absolute_path)))
    if errors:
        pairs = [_cause_and_fix(e, schema) for e in errors[:5]]
        causes = "; ".join(cause for cause, _ in pairs)
        fixes = "; ".join(dict.fromkeys(fix for _, fix in pairs))
        raise ConfigError(step_error(what, causes, fixes))
