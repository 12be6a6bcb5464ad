"""The manifest's JSON Schema: its name, its version and validation against it.

The schema ships inside the package as ``manifest.schema.json`` and is read with
:mod:`importlib.resources`, so it is found the same way from a checkout and from a wheel.

Versioning follows semver. A new MAJOR changes the meaning of existing keys: older readers
refuse it. A new MINOR only adds keys (every object in the schema accepts extra keys): readers
of an older minor still load it, and bundles of an older minor are upgraded in memory by the
migrations in :mod:`sassi_bench.bundle.migrations`.
"""

from __future__ import annotations

import functools
import json
import re
from importlib import resources
from typing import Any

from jsonschema import Draft202012Validator

from sassi_bench.bundle.errors import BundleSchemaError
from sassi_bench.errors import step_error

__all__ = [
    "SCHEMA_NAME",
    "SCHEMA_VERSION",
    "manifest_schema",
    "parse_semver",
    "schema_errors",
    "validate_manifest",
]

SCHEMA_NAME = "sassi-bench/calibration-bundle"
SCHEMA_VERSION = "1.1.0"

_SEMVER = re.compile(r"^(0|[1-9][0-9]*)\.(0|[1-9][0-9]*)\.(0|[1-9][0-9]*)$")
_MAX_REPORTED = 5
_MAX_MESSAGE = 200


@functools.cache
def manifest_schema() -> dict[str, Any]:
    """The manifest JSON Schema (Draft 2020-12) as a dict.

    Examples
    --------
    >>> manifest_schema()["properties"]["schema"]["const"]
    'sassi-bench/calibration-bundle'
    """
    text = resources.files("sassi_bench.bundle").joinpath("manifest.schema.json").read_text("utf-8")
    schema = json.loads(text)
    Draft202012Validator.check_schema(schema)
    return schema


@functools.cache
def _validator() -> Draft202012Validator:
    return Draft202012Validator(manifest_schema())


def parse_semver(text: Any) -> tuple[int, int, int] | None:
    """``"1.2.3"`` -> ``(1, 2, 3)``; None for anything that is not a plain semver string.

    Examples
    --------
    >>> parse_semver("1.10.0"), parse_semver("1.0"), parse_semver(1)
    ((1, 10, 0), None, None)
    """
    if not isinstance(text, str):
        return None
    match = _SEMVER.match(text)
    if match is None:
        return None
    major, minor, patch = (int(part) for part in match.groups())
    return major, minor, patch


def schema_errors(manifest: Any) -> list[str]:
    """Every schema violation in ``manifest`` as ``"<dotted.path>: <message>"``, sorted.

    Examples
    --------
    >>> schema_errors({"schema": "x"})[:2]
    ["<root>: 'arrays' is a required property", "<root>: 'created' is a required property"]
    """
    errors = []
    for error in _validator().iter_errors(manifest):
        where = ".".join(str(part) for part in error.absolute_path) or "<root>"
        message = error.message
        if len(message) > _MAX_MESSAGE:
            message = message[: _MAX_MESSAGE - 3] + "..."
        errors.append(f"{where}: {message}")
    return sorted(errors)


def validate_manifest(
    manifest: Any, *, step: str = "bundle load", name: str = "manifest.json"
) -> None:
    """Raise if ``manifest`` does not follow the schema.

    Parameters
    ----------
    manifest
        The parsed manifest.
    step
        The step named in the error message.
    name
        What to call the manifest in the message (usually its path).

    Raises
    ------
    BundleSchemaError
        Listing the first few violations with their dotted paths.

    Examples
    --------
    >>> validate_manifest([])  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    BundleSchemaError: bundle load: manifest.json does not follow the schema...
    """
    errors = schema_errors(manifest)
    if errors:
        shown = "; ".join(errors[:_MAX_REPORTED])
        more = f" (and {len(errors) - _MAX_REPORTED} more)" if len(errors) > _MAX_REPORTED else ""
        raise BundleSchemaError(
            step_error(
                step,
                f"{name} does not follow the {SCHEMA_NAME} schema {SCHEMA_VERSION}: {shown}{more}",
                "calibrate again, or import the bundle's exported zip "
                "(manifests must not be edited by hand)",
            )
        )
