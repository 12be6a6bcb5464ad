"""Where bundles live: ``<data_root>/<rig>/<version>/``, version names and ``LATEST``.

::

    <data_root>/<rig>/
        LATEST                 one line: the newest published version, e.g. "v0003"
        .LATEST.lock           held while LATEST is compared and replaced
        v0001/ v0002/ v0003/   published bundles (never modified)
        .publish-*/            temporary folders of publications in progress
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from sassi_bench._shared.atomic import atomic_write_text
from sassi_bench._shared.lock import LockHeldError, WriteLock
from sassi_bench.bundle.errors import BundleError
from sassi_bench.errors import step_error
from sassi_bench.paths import data_root

__all__ = [
    "LATEST_NAME",
    "check_rig_name",
    "format_version",
    "latest_version",
    "normalize_version",
    "resolve_bundle_dir",
    "resolve_bundle_ref",
    "rig_dir",
    "rig_names",
    "update_latest",
    "version_number",
    "versions",
]

LATEST_NAME = "LATEST"
#: Held while ``LATEST`` is compared and replaced (:func:`update_latest`).
LATEST_LOCK_NAME = ".LATEST.lock"
#: How long a publisher waits for another one to finish updating ``LATEST``.
LATEST_WAIT_S = 60.0
_VERSION = re.compile(r"^v([0-9]{4,9})$")
_RIG_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")


def format_version(number: int) -> str:
    """Version name of a version number.

    Examples
    --------
    >>> format_version(3), format_version(12345)
    ('v0003', 'v12345')
    """
    return f"v{number:04d}"


def version_number(name: str) -> int | None:
    """Number of a version name, or None if ``name`` is not one (``"v0003"`` -> 3).

    Examples
    --------
    >>> version_number("v0003"), version_number("latest")
    (3, None)
    """
    match = _VERSION.match(name)
    return int(match.group(1)) if match else None


def normalize_version(version: str | int) -> str:
    """Accept ``"v0003"``, ``"v3"``, ``"3"``, ``3`` or ``"latest"``; return the canonical form.

    Examples
    --------
    >>> normalize_version("v3"), normalize_version(12), normalize_version("LATEST")
    ('v0003', 'v0012', 'latest')
    """
    text = str(version).strip()
    if text.lower() == "latest":
        return "latest"
    digits = text[1:] if text[:1] in ("v", "V") else text
    if digits.isdigit() and 0 < int(digits) < 10**9:
        return format_version(int(digits))
    raise BundleError(
        step_error(
            "bundle version",
            f"{version!r} is not a version",
            "pass 'latest' or a version such as v0003 (see: sassi-bench bundle list)",
        )
    )


def check_rig_name(rig: str) -> str:
    """Return ``rig`` if it is a safe folder name, else raise :class:`BundleError`.

    Examples
    --------
    >>> check_rig_name("sim")
    'sim'
    """
    if not isinstance(rig, str) or not _RIG_NAME.match(rig) or ".." in rig:
        raise BundleError(
            step_error(
                "bundle rig",
                f"rig name {rig!r} is not a plain folder name",
                "use letters, digits, '_', '-' and '.', starting with a letter or digit",
            )
        )
    return rig


def rig_dir(rig: str, data: str | os.PathLike[str] | None = None) -> Path:
    """``<data_root>/<rig>``, with the data root resolved by :func:`sassi_bench.paths.data_root`.

    Examples
    --------
    >>> rig_dir("sim", "/tmp/lab").as_posix()
    '/tmp/lab/sim'
    """
    return data_root(data) / check_rig_name(rig)


def rig_names(data: str | os.PathLike[str] | None = None) -> list[str]:
    """Rigs that have at least one published version under the data root, sorted.

    Examples
    --------
    >>> rig_names("/nonexistent")
    []
    """
    root = data_root(data)
    if not root.is_dir():
        return []
    return sorted(
        path.name
        for path in root.iterdir()
        if path.is_dir() and _RIG_NAME.match(path.name) and versions(path)
    )


def versions(folder: Path) -> list[str]:
    """Published version folders of one rig folder, oldest first.

    Examples
    --------
    >>> versions(Path("/nonexistent"))
    []
    """
    if not folder.is_dir():
        return []
    found = []
    for path in folder.iterdir():
        number = version_number(path.name)
        if number is not None and path.is_dir() and not path.is_symlink():
            found.append((number, path.name))
    return [name for _, name in sorted(found)]


def latest_version(folder: Path) -> str | None:
    """The version ``LATEST`` names, or the highest published version if ``LATEST`` is unusable.

    Examples
    --------
    >>> latest_version(Path("/nonexistent")) is None
    True
    """
    try:
        text = (folder / LATEST_NAME).read_text("utf-8").strip()
    except (OSError, UnicodeDecodeError):
        text = ""
    if version_number(text) is not None and (folder / text).is_dir():
        return text
    found = versions(folder)
    return found[-1] if found else None


def update_latest(folder: Path, version: str, wait_s: float = LATEST_WAIT_S) -> None:
    """Point ``LATEST`` at ``version`` unless it already names a newer one.

    The comparison and the write happen under a lock (``.LATEST.lock``, waited for up to
    ``wait_s`` seconds), so of two publishers finishing together the one with the older
    version never moves ``LATEST`` back. The file is replaced atomically
    (:func:`~sassi_bench._shared.atomic.atomic_write_text`), so a reader sees either the
    old or the new content, never a partial one.

    Raises
    ------
    OSError
        When the lock is still held after ``wait_s`` seconds (``LATEST`` is unchanged).

    Examples
    --------
    >>> import tempfile
    >>> folder = Path(tempfile.mkdtemp())
    >>> for version in ("v0002", "v0003"):
    ...     (folder / version).mkdir()
    >>> update_latest(folder, "v0003"); update_latest(folder, "v0002")
    >>> (folder / LATEST_NAME).read_text()
    'v0003\\n'
    """
    lock = WriteLock(folder / LATEST_LOCK_NAME)
    try:
        lock.acquire(wait_s=wait_s)
    except LockHeldError as exc:
        raise OSError(f"{folder / LATEST_NAME} is being updated by {exc.holder}") from None
    try:
        current = latest_version(folder)
        new_number = version_number(version)
        if current is not None and new_number is not None:
            current_number = version_number(current) or 0
            if current_number > new_number:
                return
        atomic_write_text(folder / LATEST_NAME, version + "\n", overwrite=True)
    finally:
        lock.release()


def resolve_bundle_dir(
    rig: str = "sim",
    version: str | int = "latest",
    data: str | os.PathLike[str] | None = None,
) -> Path:
    """Folder of a published bundle.

    Parameters
    ----------
    rig
        Rig name (a folder under the data root).
    version
        ``"latest"`` or a version (``"v0003"``, ``3``).
    data
        Data root (``--data DIR``); defaults to ``SASSI_BENCH_DATA`` or ``calib_data/``.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    BundleError
        If the rig has no published bundle, or not that version.

    Examples
    --------
    >>> resolve_bundle_dir("sim", "latest", "/nonexistent")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    BundleError: bundle load: no calibration bundle is published for rig 'sim'...
    """
    folder = rig_dir(rig, data)
    wanted = normalize_version(version)
    if wanted == "latest":
        found = latest_version(folder)
        if found is None:
            raise BundleError(
                step_error(
                    "bundle load",
                    f"no calibration bundle is published for rig {rig!r} under {folder.parent}",
                    "run the calibration to publish one, or point --data / SASSI_BENCH_DATA "
                    "at the data root that holds it",
                )
            )
        wanted = found
    path = folder / wanted
    if not path.is_dir():
        known = ", ".join(versions(folder)) or "none"
        raise BundleError(
            step_error(
                "bundle load",
                f"rig {rig!r} has no version {wanted} under {folder.parent} (published: {known})",
                "pick a published version (sassi-bench bundle list)",
            )
        )
    return path


def resolve_bundle_ref(
    ref: str | os.PathLike[str] | None,
    *,
    rig: str = "sim",
    data: str | os.PathLike[str] | None = None,
) -> Path:
    """Folder of the bundle a person named: the one rule of every ``--bundle`` and
    ``bundle`` subcommand.

    A version of ``rig`` (``latest``, ``v0003``, ``3``; None means ``latest``) is looked
    up under the data root; anything else is the path of a bundle folder (write
    ``./v0003`` for a folder that is named like a version).

    Parameters
    ----------
    ref
        A version, ``latest``, None, or a folder path.
    rig
        Rig folder the version belongs to.
    data
        Data root (``--data DIR``; see :func:`sassi_bench.paths.data_root`).

    Returns
    -------
    pathlib.Path

    Raises
    ------
    BundleError
        If the version is not published, or the path is not a folder.

    Examples
    --------
    >>> import tempfile
    >>> folder = tempfile.mkdtemp()
    >>> resolve_bundle_ref(folder) == Path(folder)
    True
    >>> resolve_bundle_ref("latest", data="/nonexistent")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    BundleError: bundle load: no calibration bundle is published for rig 'sim'...
    """
    text = "latest" if ref is None else os.fspath(ref)
    try:
        version = normalize_version(text)
    except BundleError:
        path = Path(text)
    else:
        return resolve_bundle_dir(rig, version, data)
    if not path.exists():
        raise BundleError(
            step_error(
                "bundle",
                f"{text!r} is not a version (latest, v0003, 3) and not a bundle folder "
                "(nothing is there)",
                "name a version of --rig (see: sassi-bench bundle list) or the path of a "
                "bundle folder",
            )
        )
    return path
