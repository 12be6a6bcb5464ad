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


def _listed(keys: list[str]) -> str:
    """``'a', 'b' or 'c'``: keys quoted, for a message."""
    quoted = [repr(key) for key in keys]
    return quoted[0] if len(quoted) == 1 else f"{', '.join(quoted[:-1])} or {quoted[-1]}"


def _cause_and_fix(error: jsonschema.ValidationError) -> tuple[str, str]:
    """What is wrong at one place of the document, and what to do about it.

    The allowed keys come from the schema node that failed (``error.schema``), so a
    section reached through a ``$ref`` lists its own keys.
    """
    where = ".".join(str(p) for p in error.absolute_path)
    node = error.schema if isinstance(error.schema, dict) else {}
    instance = error.instance if isinstance(error.instance, dict) else {}
    if error.validator == "additionalProperties":
        allowed = list(node.get("properties", {}))
        extras = sorted(set(instance) - set(allowed))
        hints = [f"{key!r}{did_you_mean(key, allowed)}" for key in extras]
        key = f"{where}.{extras[0]}" if where else (extras[0] if extras else "?")
        return (
            f"{key}: unknown key {', '.join(hints)}",
            f"remove it or use one of {', '.join(allowed)}",
        )
    kind = instance.get("kind")
    of_kind = f" (kind {kind})" if isinstance(kind, str) else ""
    under = f" under {where}" if where else ""
    where = where or "(top level)"
    if error.validator == "required":
        missing = [key for key in error.validator_value if key not in instance]
        return (
            f"{where}: missing key {_listed(missing)}{of_kind}",
            f"add {', '.join(missing)}{under}",
        )
    if error.validator == "not" and instance:
        # ``not: {anyOf: [{required: [key]}, ...]}``: keys that do not apply here.
        refused = [
            key
            for branch in error.validator_value.get("anyOf", [])
            for key in branch.get("required", [])
            if key in instance
        ]
        if refused:
            return (
                f"{where}: {_listed(refused)} do{'es' if len(refused) == 1 else ''} not "
                f"apply{of_kind}",
                f"remove {', '.join(refused)} from {where}",
            )
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
        pairs = [_cause_and_fix(e) for e in errors[:5]]
        causes = "; ".join(cause for cause, _ in pairs)
        fixes = "; ".join(dict.fromkeys(fix for _, fix in pairs))
        raise ConfigError(step_error(what, causes, fixes))
