"""JSON in and out of a bundle: conversion of numpy values, manifest encoding, strict parsing.

The manifest must be plain JSON (no NaN, no Infinity, string keys only) so that any language
can read it and so that its canonical form
(:func:`~sassi_bench._shared.canonical_json.canonical_json`), used for ``rig_hash``, is
well defined.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import Any

import numpy as np

from sassi_bench.bundle.errors import BundleError, BundleSchemaError
from sassi_bench.errors import step_error

__all__ = [
    "dump_manifest",
    "freeze",
    "load_json_strict",
    "thaw",
    "to_jsonable",
]


def to_jsonable(value: Any, where: str = "value", step: str = "bundle publish") -> Any:
    """Convert ``value`` to plain JSON types (dict, list, str, int, float, bool, None).

    numpy scalars and arrays become Python numbers and (nested) lists; tuples become lists;
    paths become strings. Anything else, non-string keys and non-finite floats are refused.

    Parameters
    ----------
    value
        The object to convert.
    where
        Dotted name of ``value`` used in error messages, e.g. ``"procedure"``.
    step
        The step named in error messages.

    Returns
    -------
    Any
        A new JSON-compatible object.

    Raises
    ------
    BundleError
        If something cannot be represented in JSON.

    Examples
    --------
    >>> import numpy as np
    >>> to_jsonable({"a": np.float32(0.5), "b": (1, np.int64(2)), "c": np.eye(2)})
    {'a': 0.5, 'b': [1, 2], 'c': [[1.0, 0.0], [0.0, 1.0]]}
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.generic):
        value = value.item()
        if not isinstance(value, (bool, int, float)):
            _refuse(where, f"has numpy type {type(value).__name__}", step)
        return to_jsonable(value, where, step)
    if isinstance(value, int):
        return int(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            _refuse(where, f"is {value!r}", step, fix="use null (None) for a missing value")
        return float(value)
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biuf":
            _refuse(where, f"is an array of dtype {value.dtype}", step)
        return to_jsonable(value.tolist(), where, step)
    if isinstance(value, Mapping):
        out: dict[str, Any] = {}
        for key, item in value.items():
            if not isinstance(key, str):
                _refuse(f"{where}[{key!r}]", "has a non-string key", step)
            out[key] = to_jsonable(item, f"{where}.{key}", step)
        return out
    if isinstance(value, Sequence) and not isinstance(value, (bytes, bytearray)):
        return [to_jsonable(item, f"{where}[{i}]", step) for i, item in enumerate(value)]
    _refuse(where, f"has type {type(value).__name__}, which JSON cannot hold", step)
    raise AssertionError("unreachable")  # pragma: no cover


def _refuse(where: str, cause: str, step: str, fix: str | None = None) -> None:
    raise BundleError(
        step_error(
            step,
            f"{where} {cause}",
            fix or "pass JSON-compatible values (dict, list, str, int, float, bool, None)",
        )
    )


def dump_manifest(manifest: Mapping[str, Any]) -> bytes:
    """Human-readable manifest encoding (sorted keys, two-space indent, UTF-8, final newline).

    Examples
    --------
    >>> dump_manifest({"b": 1, "a": 2})
    b'{\\n  "a": 2,\\n  "b": 1\\n}\\n'
    """
    text = json.dumps(manifest, sort_keys=True, indent=2, ensure_ascii=False, allow_nan=False)
    return (text + "\n").encode("utf-8")


def _no_constants(name: str) -> Any:
    raise ValueError(f"{name} is not valid JSON")


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in pairs:
        if key in out:
            raise ValueError(f"duplicate key {key!r}")
        out[key] = value
    return out


def load_json_strict(data: bytes, name: str, step: str = "bundle load") -> Any:
    """Parse UTF-8 JSON, refusing NaN/Infinity and duplicate keys.

    Raises
    ------
    BundleSchemaError
        If ``data`` is not strict JSON; the message names ``name``.

    Examples
    --------
    >>> load_json_strict(b'{"a": 1}', "manifest.json")
    {'a': 1}
    """
    try:
        return json.loads(
            data.decode("utf-8"),
            parse_constant=_no_constants,
            object_pairs_hook=_no_duplicates,
        )
    except (UnicodeDecodeError, ValueError, RecursionError) as exc:
        raise BundleSchemaError(
            step_error(
                step,
                f"{name} is not valid JSON ({exc})",
                "restore the bundle from a backup or publish it again",
            )
        ) from exc


def thaw(value: Any) -> Any:
    """Deep copy of a (possibly read-only) manifest mapping as plain dicts and lists.

    Examples
    --------
    >>> from types import MappingProxyType
    >>> thaw(MappingProxyType({"a": (1, 2)}))
    {'a': [1, 2]}
    """
    if isinstance(value, Mapping):
        return {key: thaw(item) for key, item in value.items()}
    if isinstance(value, (list, tuple)):
        return [thaw(item) for item in value]
    return value


def freeze(value: Any) -> Any:
    """Deep read-only view of JSON data: dicts become mapping proxies, lists become tuples.

    Examples
    --------
    >>> frozen = freeze({"a": [1, {"b": 2}]})
    >>> frozen["a"][1]["b"], type(frozen["a"]).__name__
    (2, 'tuple')
    """
    if isinstance(value, Mapping):
        return MappingProxyType({key: freeze(item) for key, item in value.items()})
    if isinstance(value, (list, tuple)):
        return tuple(freeze(item) for item in value)
    return value
