"""Atomic, never-overwriting publication of a calibration bundle.

A bundle is built in a temporary folder beside its destination (``<data_root>/<rig>/.publish-*``,
so the final :func:`os.rename` stays on one file system and is atomic), verified there with the
same code the loader uses, then renamed to the next free version ``vNNNN``. If another process
took that number first the rename fails (the target exists and is not empty), and the writer
retries with the next number, so concurrent publishers always end with distinct, intact
versions. ``LATEST`` is then replaced atomically. A reader therefore sees either no version
folder or a complete one.
"""

from __future__ import annotations

import copy
import errno
import functools
import io
import os
import platform
import re
import shutil
import tempfile
import warnings
from collections.abc import Callable, Iterable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from sassi_bench._shared.atomic import atomic_write_bytes, fsync_dir
from sassi_bench._shared.canonical_json import canonical_json
from sassi_bench.bundle.errors import BundleError, BundleQualityError
from sassi_bench.bundle.integrity import (
    MANIFEST_CHECKSUM_NAME,
    MANIFEST_NAME,
    format_manifest_checksum,
    sha256_bytes,
)
from sassi_bench.bundle.jsonio import dump_manifest, to_jsonable
from sassi_bench.bundle.layout import (
    check_rig_name,
    format_version,
    rig_dir,
    update_latest,
    version_number,
    versions,
)
from sassi_bench.bundle.loader import ARRAYS_DIR, REPORT_DIR, read_bundle
from sassi_bench.bundle.models import CalibrationModels
from sassi_bench.bundle.quality import normalize_quality
from sassi_bench.bundle.schema import SCHEMA_NAME, SCHEMA_VERSION, validate_manifest
from sassi_bench.errors import step_error
from sassi_bench.paths import shared_mode
from sassi_bench.provenance import package_version, source_provenance

__all__ = ["ReportSource", "publish", "software_info"]

ReportSource = bytes | str | os.PathLike[str] | Callable[[Mapping[str, Any]], bytes | str]
"""What a bundle report file is made from: bytes, text, a file to copy, or a function of
the bundle's own manifest (without ``reports``), so a report can name the version it is
published as."""

STEP = "bundle publish"
_ARRAY_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_-]{0,63}$")
_REPORT_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}$")
_SHA256 = re.compile(r"^[0-9a-f]{64}$")
_MAX_ATTEMPTS = 1000


@functools.cache
def software_info() -> dict[str, Any]:
    """Versions of the software publishing a bundle (the manifest's ``software``).

    ``git_commit`` and ``git_dirty`` come from git when the package runs from a checkout,
    from what the build recorded for a regular install (see :mod:`sassi_bench.provenance`),
    and are None otherwise.

    Examples
    --------
    >>> sorted(software_info())
    ['git_commit', 'git_dirty', 'name', 'numpy', 'python', 'version']
    """
    version = package_version()
    source = source_provenance()
    return {
        "name": "sassi-bench",
        "version": version,
        "git_commit": source["git_commit"],
        "git_dirty": source["git_dirty"],
        "python": platform.python_version(),
        "numpy": np.__version__,
    }


def _bad(cause: str, fix: str) -> BundleError:
    return BundleError(step_error(STEP, cause, fix))


def _npy(name: str, value: ArrayLike) -> tuple[bytes, dict[str, Any]]:
    """Serialise one numeric array to plain .npy bytes and describe it for the manifest."""
    if not _ARRAY_NAME.match(name):
        raise _bad(
            f"array name {name!r} is not a plain file name",
            "use letters, digits, '_' and '-' (at most 64), starting with a letter, digit or '_'",
        )
    try:
        array = np.asarray(value)
    except (ValueError, TypeError) as exc:
        raise _bad(f"array {name!r} is not a regular array ({exc})", "pass a numpy array") from exc
    if array.dtype.kind not in "biufc":
        raise _bad(
            f"array {name!r} has dtype {array.dtype} (object, string and structured arrays are "
            "refused: only plain numeric arrays can be stored safely)",
            "store numbers in arrays and text in the manifest (procedure, quality)",
        )
    buffer = io.BytesIO()
    np.save(buffer, array, allow_pickle=False)
    data = buffer.getvalue()
    entry = {
        "file": f"{ARRAYS_DIR}/{name}.npy",
        "dtype": array.dtype.str,
        "shape": list(array.shape),
        "sha256": sha256_bytes(data),
    }
    return data, entry


def _check_report_name(name: str) -> None:
    if not _REPORT_NAME.match(name) or ".." in name:
        raise _bad(
            f"report name {name!r} is not a plain file name",
            "use letters, digits, '_', '-' and '.', e.g. 'dispersion_residuals.png'",
        )


def _report_bytes(name: str, value: Any) -> bytes:
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    if isinstance(value, str):
        return value.encode("utf-8")
    if isinstance(value, os.PathLike):
        try:
            return Path(value).read_bytes()
        except OSError as exc:
            raise _bad(
                f"report {name!r}: cannot read {value} ({exc})", "pass an existing file"
            ) from exc
    raise _bad(
        f"report {name!r} is a {type(value).__name__}",
        "pass bytes, text (str), a pathlib.Path to copy, or a function of the manifest",
    )


def _inputs(inputs: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    out = []
    for index, item in enumerate(inputs):
        if not isinstance(item, Mapping):
            raise _bad(
                f"inputs[{index}] is a {type(item).__name__}", "pass {'id': ..., 'sha256': ...}"
            )
        if not isinstance(item.get("id"), str) or not item["id"]:
            raise _bad(f"inputs[{index}] has no 'id'", "give each raw session its id")
        if not isinstance(item.get("sha256"), str) or not _SHA256.match(item["sha256"]):
            raise _bad(
                f"inputs[{index}] ({item['id']}) has no valid 'sha256'",
                "give the lowercase hex SHA-256 of the raw session",
            )
        out.append(to_jsonable(item, f"inputs[{index}]"))
    return out


def _write_manifest(folder: Path, manifest: dict[str, Any]) -> None:
    # Written again for every version number tried (see _rename_into_place).
    raw = dump_manifest(manifest)
    checksum = format_manifest_checksum(sha256_bytes(raw)).encode()
    atomic_write_bytes(folder / MANIFEST_NAME, raw, overwrite=True)
    atomic_write_bytes(folder / MANIFEST_CHECKSUM_NAME, checksum, overwrite=True)


def _utc_now() -> str:
    return datetime.now(UTC).isoformat(timespec="milliseconds").replace("+00:00", "Z")


def publish(
    models: CalibrationModels,
    *,
    rig: Mapping[str, Any] | Any,
    quality: Mapping[str, Any],
    procedure: Mapping[str, Any],
    inputs: Iterable[Mapping[str, Any]] = (),
    rig_name: str | None = None,
    extra_arrays: Mapping[str, ArrayLike] | None = None,
    reports: Mapping[str, ReportSource] | None = None,
    allow_failed: bool = False,
    data: str | os.PathLike[str] | None = None,
) -> Path:
    """Publish a new, immutable calibration bundle version.

    Parameters
    ----------
    models
        The fitted models.
    rig
        The rig description: a :class:`sassi_bench.rig.config.RigDescription` (anything with
        ``to_dict()``) or a JSON-compatible mapping; hashed into ``rig_hash``.
    quality
        ``{"checks": [QualityCheck, ...], "residuals": {...}, "leave_one_out": {...}}``.
    procedure
        The procedure parameters used (JSON-compatible mapping).
    inputs
        Raw sessions used: mappings with ``id`` and ``sha256`` (and any other JSON keys).
    rig_name
        Folder name of the rig under the data root; defaults to ``rig["name"]``.
    extra_arrays
        More numeric arrays to keep in the bundle (residual maps...), by name.
    reports
        Report files to keep under ``report/``, by file name: bytes, text, a
        :class:`pathlib.Path` to copy, or a function called with the new bundle's
        manifest (everything but ``reports``: its ``version``, ``created``, ``passed``,
        ``quality``...) that returns the file's bytes or text, so a report names the
        bundle it is published in.
    allow_failed
        Publish even if a quality check failed; the manifest then has ``passed: false`` and
        ``override: true``.
    data
        Data root; defaults to ``SASSI_BENCH_DATA`` or ``calib_data/``.

    Returns
    -------
    pathlib.Path
        The new bundle folder ``<data_root>/<rig>/vNNNN``.

    Raises
    ------
    BundleQualityError
        If a quality check failed and ``allow_failed`` is False (nothing is written).
    BundleError
        If an input cannot be stored (object arrays, non-JSON values, bad names...).

    Examples
    --------
    >>> from sassi_bench.bundle import QualityCheck, publish
    >>> models, rig = bundle.models, bundle.manifest["rig"]  # or new ones
    >>> path = publish(models, rig=rig, procedure={"lasers_nm": [450, 520]},
    ...                quality={"checks": [QualityCheck.at_most("rms", 0.2, 0.5, "px")]},
    ...                data="new_data")
    >>> path.name
    'v0001'
    """
    if not isinstance(models, CalibrationModels):
        raise _bad(
            f"models is a {type(models).__name__}",
            "pass a sassi_bench.bundle.CalibrationModels",
        )
    if not isinstance(rig, Mapping) and callable(getattr(rig, "to_dict", None)):
        rig = rig.to_dict()  # a sassi_bench.rig RigDescription
    if not isinstance(rig, Mapping):
        raise _bad(
            f"rig is a {type(rig).__name__}",
            "pass the rig description (a RigDescription or a mapping)",
        )
    rig_json = to_jsonable(rig, "rig")
    name = rig_name if rig_name is not None else rig_json.get("name")
    if not isinstance(name, str):
        raise _bad("the rig description has no 'name'", "pass rig_name='<rig>'")
    check_rig_name(name)
    quality_json, checks = normalize_quality(quality)
    failed = [check for check in checks if not check.passed]
    if failed and not allow_failed:
        listed = "; ".join(check.describe() for check in failed)
        raise BundleQualityError(
            step_error(
                STEP,
                f"{len(failed)} quality check(s) failed: {listed}",
                "improve the calibration and run it again, or publish anyway with "
                "--allow-failed (from Python: allow_failed=True), which marks the bundle as failed",
            )
        )
    if not isinstance(procedure, Mapping):
        raise _bad(f"procedure is a {type(procedure).__name__}", "pass a mapping of parameters")
    procedure_json = to_jsonable(procedure, "procedure")
    inputs_json = _inputs(inputs)

    models_json, arrays = models.to_manifest()
    for key, value in (extra_arrays or {}).items():
        if key in arrays:
            raise _bad(f"extra array {key!r} has the name of a model array", "rename it")
        arrays[key] = value
    payload = {key: _npy(key, value) for key, value in arrays.items()}
    for key in reports or {}:
        _check_report_name(key)
    report_payload = {
        key: _report_bytes(key, value)
        for key, value in (reports or {}).items()
        if not callable(value)
    }
    rendered = {key: value for key, value in (reports or {}).items() if callable(value)}

    base = {
        "schema": SCHEMA_NAME,
        "schema_version": SCHEMA_VERSION,
        "created": _utc_now(),
        "rig_name": name,
        "rig": rig_json,
        "rig_hash": sha256_bytes(canonical_json(rig_json)),
        "software": dict(software_info()),
        "procedure": procedure_json,
        "inputs": inputs_json,
        "models": models_json,
        "quality": quality_json,
        "passed": not failed,
        "override": bool(failed),
        "arrays": {key: entry for key, (_, entry) in payload.items()},
    }

    folder = rig_dir(name, data)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=".publish-", dir=folder))
        staging.chmod(shared_mode(directory=True))
    except OSError as exc:
        raise _bad(
            f"cannot create {folder} ({exc})", "check the data root and its permissions"
        ) from exc
    try:
        (staging / ARRAYS_DIR).mkdir()
        for raw, entry in payload.values():
            atomic_write_bytes(staging / entry["file"], raw, overwrite=False)
        if report_payload or rendered:
            (staging / REPORT_DIR).mkdir()
            for key, raw in report_payload.items():
                atomic_write_bytes(staging / REPORT_DIR / key, raw, overwrite=False)
        return _rename_into_place(staging, folder, base, report_payload, rendered)
    except OSError as exc:
        raise _bad(
            f"writing the bundle under {folder} failed ({exc})", "check free space and permissions"
        ) from exc
    finally:
        if staging.exists():
            shutil.rmtree(staging, ignore_errors=True)


def _render_reports(
    staging: Path,
    manifest: dict[str, Any],
    written: Mapping[str, bytes],
    rendered: Mapping[str, Callable[[Mapping[str, Any]], bytes | str]],
) -> dict[str, Any]:
    """Write the reports rendered for this manifest; every report's manifest entry."""
    contents = dict(written)
    for key, render in rendered.items():
        contents[key] = _report_bytes(key, render(copy.deepcopy(manifest)))
        atomic_write_bytes(staging / REPORT_DIR / key, contents[key], overwrite=True)
    return {
        key: {"file": f"{REPORT_DIR}/{key}", "sha256": sha256_bytes(raw)}
        for key, raw in sorted(contents.items())
    }


def _rename_into_place(
    staging: Path,
    folder: Path,
    base: dict[str, Any],
    written: Mapping[str, bytes],
    rendered: Mapping[str, Callable[[Mapping[str, Any]], bytes | str]],
) -> Path:
    """Give the staged bundle the next free version; retry when another process wins a number.

    Reports rendered from the manifest are rendered again for each number tried.
    """
    candidate = 1
    for _ in range(_MAX_ATTEMPTS):
        existing = [version_number(v) or 0 for v in versions(folder)]
        number = max([candidate, *(n + 1 for n in existing)])
        older = [n for n in existing if n < number]
        version = format_version(number)
        manifest = {
            **base,
            "version": version,
            "parent": format_version(max(older)) if older else None,
        }
        manifest["reports"] = _render_reports(staging, manifest, written, rendered)
        validate_manifest(manifest, step=STEP, name="the new manifest")
        _write_manifest(staging, manifest)
        read_bundle(staging, step=STEP)  # the same checks a consumer will run
        target = folder / version
        candidate = number + 1
        if target.exists():
            continue
        try:
            os.rename(staging, target)
        except OSError as exc:
            # Another publisher took this number between our scan and our rename.
            if exc.errno in (errno.EEXIST, errno.ENOTEMPTY) or target.exists():
                continue
            raise
        fsync_dir(folder)
        try:
            update_latest(folder, version)
        except OSError as exc:  # the bundle is published; only the pointer is stale
            warnings.warn(
                f"{STEP}: {version} is published but {folder / 'LATEST'} could not be updated "
                f"({exc}). Fix: write '{version}' into it by hand",
                RuntimeWarning,
                stacklevel=3,
            )
        return target
    raise _bad(
        f"no free version number under {folder} after {_MAX_ATTEMPTS} attempts",
        "check that the rig folder holds only bundle versions",
    )
