"""Verifying loader: a bundle is used only after its schema and every checksum verify.

Order of checks (the first failure raises, naming the file):

1. ``manifest.json`` against ``manifest.sha256``;
2. strict JSON, schema name, schema major version (an unknown major is refused; an older
   minor is migrated in memory, see :mod:`sassi_bench.bundle.migrations`);
3. the JSON Schema, then the cross-field rules the schema cannot express (``passed`` agrees
   with the checks, ``rig_hash`` with ``rig``, the folder name with ``version``...);
4. the file set: exactly ``manifest.json``, ``manifest.sha256`` and the listed arrays and
   reports, no symlinks;
5. each array's SHA-256, then ``np.load(..., allow_pickle=False)`` of the verified bytes, its
   dtype and shape;
6. the models against the model contract (:mod:`sassi_bench.bundle.models`).
"""

from __future__ import annotations

import io
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench._shared.canonical_json import canonical_json
from sassi_bench.bundle import migrations
from sassi_bench.bundle.bundle import CalibrationBundle
from sassi_bench.bundle.errors import BundleError, BundleIntegrityError, BundleSchemaError
from sassi_bench.bundle.integrity import (
    MANIFEST_CHECKSUM_NAME,
    MANIFEST_NAME,
    parse_manifest_checksum,
    sha256_bytes,
)
from sassi_bench.bundle.jsonio import freeze, load_json_strict
from sassi_bench.bundle.layout import resolve_bundle_dir, version_number
from sassi_bench.bundle.models import CalibrationModels
from sassi_bench.bundle.quality import format_tolerance
from sassi_bench.bundle.schema import SCHEMA_NAME, validate_manifest
from sassi_bench.errors import SassiBenchError, step_error

__all__ = ["VerifiedBundle", "load", "read_bundle", "verify"]

ARRAYS_DIR = "arrays"
REPORT_DIR = "report"
_RESTORE = (
    "repair it from its exported zip (sassi-bench bundle import ZIP checks the copy present and "
    "replaces damaged files), or restore it from a backup, or publish a new version"
)


@dataclass(frozen=True, eq=False)
class VerifiedBundle:
    """What :func:`read_bundle` checked: the manifest, the arrays and the models."""

    path: Path
    manifest: dict[str, Any]
    arrays: dict[str, NDArray[Any]]
    models: CalibrationModels
    migrated_from: str | None
    files: tuple[str, ...]


def _integrity(
    step: str, path: Path, file: str, cause: str, fix: str = _RESTORE
) -> BundleIntegrityError:
    return BundleIntegrityError(step_error(f"{step} {path}", f"{file}: {cause}", fix), file=file)


def _schema(step: str, path: Path, cause: str) -> BundleSchemaError:
    return BundleSchemaError(
        step_error(
            f"{step} {path}",
            cause,
            "calibrate again, or import the bundle's exported zip "
            "(manifests must not be edited by hand)",
        )
    )


def _read(step: str, path: Path, file: str) -> bytes:
    target = path / file
    if target.is_symlink():
        raise _integrity(step, path, file, "is a symbolic link; a bundle must be self-contained")
    try:
        return target.read_bytes()
    except FileNotFoundError:
        raise _integrity(step, path, file, "is missing") from None
    except OSError as exc:
        raise _integrity(step, path, file, f"cannot be read ({exc.strerror or exc})") from exc


def _check_file_set(step: str, path: Path, expected: set[str]) -> None:
    """Refuse symlinks, missing files and files the manifest does not list."""
    for root, dirs, files in os.walk(path):
        rel_root = Path(root).relative_to(path)
        for name in dirs:
            rel = (rel_root / name).as_posix()
            if Path(root, name).is_symlink():
                raise _integrity(
                    step, path, rel, "is a symbolic link; a bundle must be self-contained"
                )
            if rel not in (ARRAYS_DIR, REPORT_DIR):
                raise _integrity(
                    step,
                    path,
                    rel + "/",
                    "is not part of the bundle format",
                    "remove it; a bundle holds only manifest.json, manifest.sha256, "
                    "arrays/ and report/",
                )
        for name in files:
            rel = (rel_root / name).as_posix()
            if Path(root, name).is_symlink():
                raise _integrity(
                    step, path, rel, "is a symbolic link; a bundle must be self-contained"
                )
            if rel not in expected:
                raise _integrity(
                    step,
                    path,
                    rel,
                    "is not listed in the manifest",
                    "remove it (a published bundle must not be modified) or restore the bundle",
                )
    for rel in sorted(expected):
        if not (path / rel).is_file():
            raise _integrity(step, path, rel, "is missing")


def _check_manifest_rules(step: str, path: Path, manifest: Mapping[str, Any]) -> None:
    """Cross-field rules the JSON Schema cannot express."""
    checks = manifest["quality"]["checks"]
    for check in checks:
        comparison = check.get("comparison", "<=")
        value, tolerance = check["value"], check["tolerance"]
        holds = value <= tolerance if comparison == "<=" else value >= tolerance
        if check["passed"] != holds:
            raise _schema(
                step,
                path,
                f"quality check {check['name']!r} says passed={check['passed']} but "
                f"{value:g} {comparison} {format_tolerance(tolerance)} is {holds}",
            )
    all_passed = all(check["passed"] for check in checks)
    if manifest["passed"] != all_passed:
        raise _schema(
            step, path, f"passed is {manifest['passed']} but the quality checks say {all_passed}"
        )
    if manifest["override"] != (not manifest["passed"]):
        raise _schema(step, path, "override must be true exactly when passed is false")
    names = [check["name"] for check in checks]
    if len(set(names)) != len(names):
        raise _schema(step, path, "quality.checks has duplicate names")
    expected_hash = sha256_bytes(canonical_json(manifest["rig"]))
    if manifest["rig_hash"] != expected_hash:
        raise _schema(step, path, "rig_hash does not match the canonical JSON of rig")
    number = version_number(manifest["version"]) or 0
    parent = manifest["parent"]
    if parent is not None and (version_number(parent) or 0) >= number:
        raise _schema(
            step, path, f"parent {parent} is not older than version {manifest['version']}"
        )
    if version_number(path.name) is not None and path.name != manifest["version"]:
        raise _integrity(
            step,
            path,
            MANIFEST_NAME,
            f"records version {manifest['version']} but the folder is named {path.name}",
            "rename the folder back to its version (published folders must not be renamed)",
        )
    for name, entry in manifest["arrays"].items():
        if entry["file"] != f"{ARRAYS_DIR}/{name}.npy":
            raise _schema(step, path, f"arrays.{name}.file must be {ARRAYS_DIR}/{name}.npy")
    for name, entry in manifest.get("reports", {}).items():
        if entry["file"] != f"{REPORT_DIR}/{name}":
            raise _schema(step, path, f"reports.{name}.file must be {REPORT_DIR}/{name}")


def _parse_manifest(step: str, path: Path) -> tuple[dict[str, Any], str | None]:
    raw = _read(step, path, MANIFEST_NAME)
    checksum_raw = _read(step, path, MANIFEST_CHECKSUM_NAME)
    try:
        recorded = parse_manifest_checksum(checksum_raw.decode("utf-8"))
    except (UnicodeDecodeError, BundleIntegrityError):
        raise _integrity(
            step,
            path,
            MANIFEST_CHECKSUM_NAME,
            f"is not one line '<64 hex digits>  {MANIFEST_NAME}'",
        ) from None
    actual = sha256_bytes(raw)
    if actual != recorded:
        raise _integrity(
            step,
            path,
            MANIFEST_NAME,
            f"SHA-256 is {actual[:12]}... but {MANIFEST_CHECKSUM_NAME} records {recorded[:12]}...; "
            "the manifest was changed or corrupted after publishing",
        )
    manifest = load_json_strict(raw, f"{path / MANIFEST_NAME}", step=step)
    if not isinstance(manifest, dict):
        raise _schema(
            step, path, f"{MANIFEST_NAME} holds a JSON {type(manifest).__name__}, not an object"
        )
    if manifest.get("schema") != SCHEMA_NAME:
        raise _schema(
            step,
            path,
            f"{MANIFEST_NAME} has schema {manifest.get('schema')!r}, not {SCHEMA_NAME!r}; "
            "it is not a sassi-bench calibration bundle",
        )
    migrated, migrated_from = migrations.REGISTRY.migrate(manifest, step=f"{step} {path}")
    validate_manifest(migrated, step=f"{step} {path}", name=MANIFEST_NAME)
    _check_manifest_rules(step, path, migrated)
    return migrated, migrated_from


def _load_arrays(step: str, path: Path, manifest: Mapping[str, Any]) -> dict[str, NDArray[Any]]:
    arrays: dict[str, NDArray[Any]] = {}
    for name, entry in sorted(manifest["arrays"].items()):
        file = entry["file"]
        data = _read(step, path, file)
        actual = sha256_bytes(data)
        if actual != entry["sha256"]:
            raise _integrity(
                step,
                path,
                file,
                f"SHA-256 is {actual[:12]}... but the manifest records {entry['sha256'][:12]}...; "
                "the file was changed, truncated or corrupted after publishing "
                f"({len(data)} bytes)",
            )
        try:
            array = np.load(io.BytesIO(data), allow_pickle=False)
        except (ValueError, OSError, EOFError, TypeError) as exc:
            raise _integrity(step, path, file, f"is not a readable .npy array ({exc})") from exc
        if not isinstance(array, np.ndarray):
            raise _integrity(step, path, file, "is not a single .npy array")
        if array.dtype.str != entry["dtype"] or list(array.shape) != list(entry["shape"]):
            raise _integrity(
                step,
                path,
                file,
                f"holds {array.dtype.str} {tuple(array.shape)} but the manifest records "
                f"{entry['dtype']} {tuple(entry['shape'])}",
            )
        array.flags.writeable = False
        arrays[name] = array
    return arrays


def _check_reports(step: str, path: Path, manifest: Mapping[str, Any]) -> None:
    for entry in manifest.get("reports", {}).values():
        data = _read(step, path, entry["file"])
        if sha256_bytes(data) != entry["sha256"]:
            raise _integrity(
                step,
                path,
                entry["file"],
                "SHA-256 does not match the manifest; the report was changed after publishing",
            )


def read_bundle(path: str | os.PathLike[str], *, step: str = "bundle load") -> VerifiedBundle:
    """Verify a bundle folder completely and return its parsed content.

    Parameters
    ----------
    path
        The bundle folder (or its ``manifest.json``).
    step
        The step named in error messages (``"bundle load"``, ``"bundle verify"``...).

    Returns
    -------
    VerifiedBundle

    Raises
    ------
    BundleIntegrityError
        A file is missing, extra, a symlink, or does not match its checksum; ``.file`` names it.
    UnsupportedSchemaError
        The manifest's schema major version is not supported.
    BundleSchemaError
        The manifest or a model breaks the schema or the model contract.

    Examples
    --------
    >>> verified = read_bundle("calib_data/sim/v0001")
    >>> sorted(verified.arrays)[:2]
    ['bin_centres_nm', 'bin_edges_nm']
    """
    folder = Path(path)
    if folder.name == MANIFEST_NAME:
        folder = folder.parent
    if not folder.is_dir():
        raise BundleError(
            step_error(
                step,
                f"{folder} is not a bundle folder (it does not exist or is not a directory)",
                "pass the folder that holds manifest.json, e.g. calib_data/sim/v0001",
            )
        )
    manifest, migrated_from = _parse_manifest(step, folder)
    expected = {MANIFEST_NAME, MANIFEST_CHECKSUM_NAME}
    expected.update(entry["file"] for entry in manifest["arrays"].values())
    expected.update(entry["file"] for entry in manifest.get("reports", {}).values())
    _check_file_set(step, folder, expected)
    arrays = _load_arrays(step, folder, manifest)
    _check_reports(step, folder, manifest)
    try:
        models = CalibrationModels.from_manifest(manifest["models"], arrays)
    except SassiBenchError as exc:
        raise BundleSchemaError(f"{step} {folder}: {exc}") from exc
    except (TypeError, ValueError, KeyError, IndexError, ArithmeticError) as exc:
        # Defensive net: a model the contract checks did not anticipate is still a
        # malformed bundle, never a crash.
        raise _schema(step, folder, f"models are malformed ({type(exc).__name__}: {exc})") from exc
    return VerifiedBundle(
        path=folder,
        manifest=manifest,
        arrays=arrays,
        models=models,
        migrated_from=migrated_from,
        files=tuple(sorted(expected)),
    )


def load(
    path: str | os.PathLike[str] | None = None,
    *,
    rig: str = "sim",
    version: str | int = "latest",
    data: str | os.PathLike[str] | None = None,
) -> CalibrationBundle:
    """Load a calibration bundle after verifying its schema and every checksum.

    Parameters
    ----------
    path
        A bundle folder. When given, ``rig``, ``version`` and ``data`` are ignored.
    rig
        Rig name, a folder under the data root.
    version
        ``"latest"`` (what ``<data_root>/<rig>/LATEST`` names) or a version (``"v0003"``, ``3``).
    data
        Data root; defaults to ``SASSI_BENCH_DATA`` or ``calib_data/`` (see
        :func:`sassi_bench.paths.data_root`).

    Returns
    -------
    CalibrationBundle
        Immutable: read-only arrays and manifest.

    Raises
    ------
    BundleError
        Or a subclass (:class:`BundleIntegrityError`, :class:`BundleSchemaError`,
        :class:`UnsupportedSchemaError`) naming the file, the cause and the fix.

    Examples
    --------
    >>> from sassi_bench.bundle import load
    >>> bundle = load(rig="sim", data="calib_data")
    >>> bundle = load("calib_data/sim/v0002")
    >>> bundle.wavelengths.shape
    (68,)
    """
    folder = Path(path) if path is not None else resolve_bundle_dir(rig, version, data)
    verified = read_bundle(folder, step="bundle load")
    return CalibrationBundle(
        path=verified.path,
        manifest=freeze(verified.manifest),
        models=verified.models,
        arrays=freeze(verified.arrays),
        migrated_from=verified.migrated_from,
    )


def verify(path: str | os.PathLike[str]) -> tuple[str, ...]:
    """Verify a bundle folder; return the files checked, or raise naming the failing one.

    Examples
    --------
    >>> verify("calib_data/sim/v0001")[-3:]
    ('manifest.json', 'manifest.sha256', 'report/summary.txt')
    """
    return read_bundle(path, step="bundle verify").files
