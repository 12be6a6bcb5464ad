"""Zip export and import of a bundle, for moving calibrations between machines.

The zip holds the bundle's files at its top level (``manifest.json``, ``manifest.sha256``,
``arrays/*.npy``, ``report/*``). Import treats the archive as untrusted: every entry name is
checked before anything is written (no absolute paths, no ``..``, no symlinks, no unexpected
names, a size limit), the bundle is extracted into a temporary folder beside its destination,
verified completely like any loaded bundle, and only then renamed into place. An existing
version is never overwritten with other content; when the same bundle is already there,
that copy is verified too, and each of its files that does not verify (a flipped bit, a
truncated or missing file) is replaced by the zip's verified one.
"""

from __future__ import annotations

import errno
import os
import re
import shutil
import stat
import tempfile
import zipfile
from pathlib import Path
from typing import NamedTuple

from sassi_bench._shared.atomic import atomic_path, fsync_dir, fsync_file
from sassi_bench.bundle.errors import (
    BundleError,
    BundleIntegrityError,
    BundleSchemaError,
    UnsafeArchiveError,
)
from sassi_bench.bundle.integrity import MANIFEST_CHECKSUM_NAME, MANIFEST_NAME, sha256_file
from sassi_bench.bundle.jsonio import load_json_strict
from sassi_bench.bundle.layout import (
    check_rig_name,
    rig_dir,
    update_latest,
    version_number,
)
from sassi_bench.bundle.loader import ARRAYS_DIR, REPORT_DIR, read_bundle
from sassi_bench.errors import step_error
from sassi_bench.paths import shared_mode

__all__ = ["ImportedBundle", "export_zip", "import_zip", "verify_zip"]

#: Default limit on the total uncompressed size of an imported archive.
MAX_IMPORT_BYTES = 2 * 1024**3
_ZIP_DATE = (1980, 1, 1, 0, 0, 0)  # fixed, so the same bundle always gives the same zip
_MEMBER = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,127}$")
_CHUNK = 1 << 20


class ImportedBundle(NamedTuple):
    """Result of :func:`import_zip`."""

    path: Path
    #: False when the same bundle was already there.
    created: bool
    #: Files of a copy already there that did not verify, replaced from the zip.
    repaired: tuple[str, ...] = ()


def export_zip(path: str | os.PathLike[str], out: str | os.PathLike[str]) -> Path:
    """Verify a bundle and write it to a zip archive.

    Parameters
    ----------
    path
        The bundle folder.
    out
        The zip file to create; must not exist.

    Returns
    -------
    pathlib.Path
        ``out``.

    Raises
    ------
    BundleError
        If the bundle does not verify or ``out`` exists.

    Examples
    --------
    >>> export_zip("calib_data/sim/v0001", "sim-v0001.zip")
    PosixPath('sim-v0001.zip')
    """
    verified = read_bundle(path, step="bundle export")
    out_path = Path(out)
    if out_path.exists():
        raise BundleError(
            step_error(
                "bundle export",
                f"{out_path} already exists",
                "choose another file name or delete it",
            )
        )
    if not out_path.parent.is_dir():
        raise BundleError(
            step_error(
                "bundle export",
                f"the folder {out_path.parent} does not exist",
                "create it first, or write the zip elsewhere",
            )
        )
    order = sorted(
        verified.files, key=lambda f: (f not in (MANIFEST_NAME, MANIFEST_CHECKSUM_NAME), f)
    )
    try:
        with (
            atomic_path(out_path, overwrite=False) as temporary,
            zipfile.ZipFile(temporary, "x", compression=zipfile.ZIP_DEFLATED) as archive,
        ):
            for file in order:
                info = zipfile.ZipInfo(file, date_time=_ZIP_DATE)
                info.external_attr = (stat.S_IFREG | 0o644) << 16
                info.compress_type = zipfile.ZIP_DEFLATED
                archive.writestr(info, (verified.path / file).read_bytes())
    except OSError as exc:
        raise BundleError(
            step_error(
                "bundle export",
                f"cannot write {out_path} ({exc})",
                "check the folder and free space",
            )
        ) from exc
    return out_path


def _unsafe(zip_path: Path, name: str, cause: str) -> UnsafeArchiveError:
    return UnsafeArchiveError(
        step_error(
            "bundle import",
            f"{zip_path}: entry {name!r} {cause}",
            "import only zips made by 'sassi-bench bundle export'; this archive was altered "
            "or is not a bundle",
        ),
        file=name,
    )


def _too_big(zip_path: Path, cause: str) -> UnsafeArchiveError:
    return UnsafeArchiveError(
        step_error(
            "bundle import",
            f"{zip_path} {cause}",
            "check where the archive came from; pass a larger max_bytes to import_zip if the "
            "bundle is genuinely that large",
        ),
        file=str(zip_path),
    )


def _member_parts(zip_path: Path, info: zipfile.ZipInfo) -> tuple[str, ...] | None:
    """Validated path parts of a member; None for an allowed directory entry."""
    name = info.filename
    if "\\" in name or name.startswith("/") or re.match(r"^[A-Za-z]:", name):
        raise _unsafe(zip_path, name, "is an absolute path or uses backslashes")
    mode = info.external_attr >> 16
    if stat.S_ISLNK(mode):
        raise _unsafe(zip_path, name, "is a symbolic link")
    if info.flag_bits & 0x1:
        raise _unsafe(zip_path, name, "is encrypted")
    is_dir = name.endswith("/")
    parts = tuple(name.rstrip("/").split("/")) if is_dir else tuple(name.split("/"))
    if any(part in ("", ".", "..") for part in parts):
        raise _unsafe(zip_path, name, "has an empty, '.' or '..' path component")
    if is_dir:
        if parts in ((ARRAYS_DIR,), (REPORT_DIR,)):
            return None
        raise _unsafe(zip_path, name, "is a folder the bundle format does not have")
    if stat.S_ISDIR(mode):
        raise _unsafe(zip_path, name, "is a folder the bundle format does not have")
    if parts in ((MANIFEST_NAME,), (MANIFEST_CHECKSUM_NAME,)):
        return parts
    if len(parts) == 2 and parts[0] in (ARRAYS_DIR, REPORT_DIR) and _MEMBER.match(parts[1]):
        return parts
    raise _unsafe(
        zip_path,
        name,
        f"is not an expected name (only {MANIFEST_NAME}, {MANIFEST_CHECKSUM_NAME}, "
        f"{ARRAYS_DIR}/<name>.npy and {REPORT_DIR}/<name>)",
    )


def _members(
    source: Path, archive: zipfile.ZipFile, max_bytes: int
) -> dict[tuple[str, ...], zipfile.ZipInfo]:
    """Every file entry of the archive by validated path parts; raise on anything unsafe."""
    members: dict[tuple[str, ...], zipfile.ZipInfo] = {}
    total = 0
    for info in archive.infolist():
        parts = _member_parts(source, info)
        if parts is None:
            continue
        if parts in members:
            raise _unsafe(source, info.filename, "appears twice")
        members[parts] = info
        total += info.file_size
    if total > max_bytes:
        raise _too_big(source, f"expands to {total} bytes, more than the {max_bytes} bytes allowed")
    return members


def _open_zip(zip_path: Path) -> zipfile.ZipFile:
    try:
        return zipfile.ZipFile(zip_path)
    except FileNotFoundError:
        raise BundleError(
            step_error(
                "bundle import", f"{zip_path} does not exist", "pass the path of an exported zip"
            )
        ) from None
    except (zipfile.BadZipFile, OSError) as exc:
        raise BundleIntegrityError(
            step_error(
                "bundle import",
                f"{zip_path} is not a readable zip ({exc})",
                "export the bundle again",
            ),
            file=str(zip_path),
        ) from exc


def import_zip(
    zip_path: str | os.PathLike[str],
    *,
    rig: str | None = None,
    data: str | os.PathLike[str] | None = None,
    max_bytes: int = MAX_IMPORT_BYTES,
) -> ImportedBundle:
    """Import an exported bundle zip into the data root, after verifying everything.

    Parameters
    ----------
    zip_path
        The archive made by :func:`export_zip`.
    rig
        Expected rig name; defaults to the manifest's ``rig_name``. A mismatch is refused.
    data
        Data root; defaults to ``SASSI_BENCH_DATA`` or ``calib_data/``.
    max_bytes
        Refuse archives that expand to more than this many bytes.

    Returns
    -------
    ImportedBundle
        The bundle folder, whether it was created (False if the same bundle was already
        there), and the files of that copy that were damaged and replaced from the zip.

    Raises
    ------
    UnsafeArchiveError
        If an entry could escape the bundle folder or is not part of the bundle format.
    BundleIntegrityError, BundleSchemaError
        If the extracted bundle does not verify.
    BundleError
        If that version already exists with different content, or the rig does not match.

    Examples
    --------
    >>> zipped = export_zip("calib_data/sim/v0001", "sim-v0001.zip")
    >>> import_zip("sim-v0001.zip", data="lab_data")
    ImportedBundle(path=PosixPath('lab_data/sim/v0001'), created=True, repaired=())
    """
    source = Path(zip_path)
    with _open_zip(source) as archive:
        members = _members(source, archive, max_bytes)
        if (MANIFEST_NAME,) not in members:
            raise BundleIntegrityError(
                step_error(
                    "bundle import",
                    f"{source} has no {MANIFEST_NAME}",
                    "export the bundle again with 'sassi-bench bundle export'",
                ),
                file=MANIFEST_NAME,
            )
        manifest = load_json_strict(
            archive.read(members[(MANIFEST_NAME,)]),
            f"{source}:{MANIFEST_NAME}",
            step="bundle import",
        )
        bundle_rig, _ = _identity(source, manifest)
        if rig is not None and rig != bundle_rig:
            raise BundleError(
                step_error(
                    "bundle import",
                    f"{source} holds a bundle of rig {bundle_rig!r}, not {rig!r}",
                    f"import it with --rig {bundle_rig} (or without --rig)",
                )
            )
        folder = rig_dir(bundle_rig, data)
        folder.mkdir(parents=True, exist_ok=True)
        staging = Path(tempfile.mkdtemp(prefix=".import-", dir=folder))
        staging.chmod(shared_mode(directory=True))
        try:
            _extract(source, archive, members, staging, max_bytes)
            verified = read_bundle(staging, step="bundle import")
            return _place(source, staging, folder, verified.manifest["version"], verified.files)
        finally:
            if staging.exists():
                shutil.rmtree(staging, ignore_errors=True)


def _identity(source: Path, manifest: object) -> tuple[str, str]:
    rig = manifest.get("rig_name") if isinstance(manifest, dict) else None
    version = manifest.get("version") if isinstance(manifest, dict) else None
    if not isinstance(rig, str) or not isinstance(version, str) or version_number(version) is None:
        raise BundleIntegrityError(
            step_error(
                "bundle import",
                f"{source}: {MANIFEST_NAME} has no valid rig_name and version",
                "export the bundle again with 'sassi-bench bundle export'",
            ),
            file=MANIFEST_NAME,
        )
    return check_rig_name(rig), version


def _extract(
    source: Path,
    archive: zipfile.ZipFile,
    members: dict[tuple[str, ...], zipfile.ZipInfo],
    staging: Path,
    max_bytes: int,
) -> None:
    written = 0
    root = staging.resolve()
    for parts, info in members.items():
        target = staging.joinpath(*parts)
        if root not in target.resolve().parents:  # belt and braces after _member_parts
            raise _unsafe(source, info.filename, "would be written outside the bundle folder")
        target.parent.mkdir(exist_ok=True)
        with archive.open(info) as src, open(target, "xb") as dst:
            # Count real bytes: the sizes in a zip's directory can lie.
            for chunk in iter(lambda src=src: src.read(_CHUNK), b""):
                written += len(chunk)
                if written > max_bytes:
                    raise _too_big(source, f"expands past the {max_bytes} bytes allowed")
                dst.write(chunk)


def _same_bundle(staging: Path, target: Path) -> bool:
    """Whether ``target`` holds the bundle staged from the zip: the same manifest, or (a
    damaged manifest) the same manifest checksum file naming the zip's manifest."""
    present, staged = target / MANIFEST_NAME, staging / MANIFEST_NAME
    if present.is_file() and sha256_file(present) == sha256_file(staged):
        return True
    checksum = target / MANIFEST_CHECKSUM_NAME
    return (
        checksum.is_file()
        and checksum.read_bytes() == (staging / MANIFEST_CHECKSUM_NAME).read_bytes()
    )


def _repair(staging: Path, target: Path, files: tuple[str, ...]) -> tuple[str, ...]:
    """Verify the copy already at ``target``; replace each of its files that differs
    from the verified ``staging`` copy (one atomic rename each). The damaged files."""
    try:
        read_bundle(target, step="bundle import")
        return ()
    except (BundleIntegrityError, BundleSchemaError):
        pass
    damaged = tuple(
        file
        for file in files
        if (target / file).is_symlink()
        or not (target / file).is_file()
        or sha256_file(target / file) != sha256_file(staging / file)
    )
    for file in damaged:
        (target / file).parent.mkdir(exist_ok=True)
        fsync_file(staging / file)
        os.replace(staging / file, target / file)
        fsync_dir((target / file).parent)
    read_bundle(target, step="bundle import")  # what is still wrong (an extra file) raises
    return damaged


def _place(
    source: Path, staging: Path, folder: Path, version: str, files: tuple[str, ...]
) -> ImportedBundle:
    target = folder / version
    if target.exists():
        if _same_bundle(staging, target):
            return ImportedBundle(target, created=False, repaired=_repair(staging, target, files))
        raise BundleError(
            step_error(
                "bundle import",
                f"{target} already exists with different content than {source}",
                "versions are never overwritten: import into another data root (--data DIR)",
            )
        )
    try:
        os.rename(staging, target)
    except OSError as exc:
        if exc.errno in (errno.EEXIST, errno.ENOTEMPTY) or target.exists():
            raise BundleError(
                step_error(
                    "bundle import",
                    f"{target} was created by another process during the import",
                    "check it with 'sassi-bench bundle verify'; versions are never overwritten",
                )
            ) from exc
        raise
    fsync_dir(folder)
    update_latest(folder, version)
    return ImportedBundle(target, created=True)


def verify_zip(
    zip_path: str | os.PathLike[str], *, max_bytes: int = MAX_IMPORT_BYTES
) -> tuple[str, ...]:
    """Check an exported zip as :func:`import_zip` would, without importing it.

    Returns
    -------
    tuple of str
        The bundle files verified.

    Examples
    --------
    >>> zipped = export_zip("calib_data/sim/v0001", "sim-v0001.zip")
    >>> verify_zip("sim-v0001.zip")[-3:]
    ('manifest.json', 'manifest.sha256', 'report/summary.txt')
    """
    source = Path(zip_path)
    with _open_zip(source) as archive, tempfile.TemporaryDirectory(prefix="sassi-verify-") as tmp:
        members = _members(source, archive, max_bytes)
        staging = Path(tmp) / "bundle"
        staging.mkdir()
        _extract(source, archive, members, staging, max_bytes)
        return read_bundle(staging, step="bundle verify").files
