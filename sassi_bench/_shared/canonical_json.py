"""Canonical JSON: the one byte form every hash of a JSON value is taken over.

Plans (``plan_sha256``), rig descriptions (``rig_sha256`` of a session, ``rig_hash`` of a
bundle) and the lines of a session's event log are hashed or stored in this form, so its
bytes must never change: a change would silently give every recorded session and bundle
another identity. The form is :func:`json.dumps` with

- ``sort_keys=True``: key order does not matter;
- ``separators=(",", ":")``: no spaces;
- ``ensure_ascii=True``: every non-ASCII character is a ``\\uXXXX`` escape, so the text is
  pure ASCII and its bytes are the same in ASCII and UTF-8 (the rig description hashed
  the UTF-8 encoding of this text, plans and bundles the ASCII one: identical bytes);
- ``allow_nan=False``: NaN and infinities, which JSON cannot hold, raise
  :class:`ValueError` instead of producing the non-standard ``NaN`` token.

Floats are written by Python's shortest round-trip ``repr``.

Examples
--------
>>> canonical_json({"b": 1, "a": [0.5, None, "µm"]})
b'{"a":[0.5,null,"\\\\u00b5m"],"b":1}'
"""

from __future__ import annotations

import hashlib
import json
from typing import Any

__all__ = ["canonical_json", "canonical_sha256"]


def canonical_json(value: Any) -> bytes:
    """The canonical JSON bytes of a JSON-compatible value (see the module docstring).

    Parameters
    ----------
    value
        dicts with string keys, lists, strings, finite numbers, booleans and None.

    Returns
    -------
    bytes
        ASCII bytes: sorted keys, no spaces, non-ASCII characters escaped.

    Raises
    ------
    ValueError
        If ``value`` holds NaN or an infinity.
    TypeError
        If ``value`` holds something JSON cannot (a set, a NumPy scalar...).

    Examples
    --------
    >>> canonical_json({"b": 1, "a": [1.5, None]})
    b'{"a":[1.5,null],"b":1}'
    """
    return json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False).encode("ascii")


def canonical_sha256(value: Any) -> str:
    """SHA-256 (lowercase hex) of :func:`canonical_json` of ``value``.

    Parameters
    ----------
    value
        A JSON-compatible value (see :func:`canonical_json`).

    Returns
    -------
    str
        64 hex digits.

    Examples
    --------
    >>> canonical_sha256({"b": 1, "a": 2}) == canonical_sha256({"a": 2, "b": 1})
    True
    >>> canonical_sha256({})[:12]
    '44136fa355b3'
    """
    return hashlib.sha256(canonical_json(value)).hexdigest()
