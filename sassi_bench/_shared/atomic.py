"""Atomic file writes: a reader sees the old file, or the whole new one, never a part.

Every writer of the workbench goes the same way: write beside the target under a hidden
temporary name (``.<name>.<random>.tmp``, same folder, so the rename stays on one file
system), flush and fsync the file, rename it into place, then fsync the folder so the
rename itself survives a power cut. A failure at any point removes the temporary file and
leaves the target as it was.

The temporary file is created with :func:`open` mode ``"x"``, so it gets the permission
bits of the process umask (``tempfile.mkstemp`` would make it private: sessions and
bundles are shared lab records).

Examples
--------
>>> import tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> atomic_write_text(folder / "LATEST", "v0001\\n", overwrite=True).read_text()
'v0001\\n'
>>> sorted(p.name for p in folder.iterdir())  # no temporary file is left behind
['LATEST']
"""

from __future__ import annotations

import contextlib
import os
import uuid
from collections.abc import Iterator
from pathlib import Path

__all__ = [
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "fsync_dir",
    "fsync_file",
    "temporary_sibling",
]


def temporary_sibling(path: str | os.PathLike[str]) -> Path:
    """A fresh hidden name beside ``path``: ``.<name>.<12 hex digits>.tmp``.

    Parameters
    ----------
    path
        The final file or folder.

    Returns
    -------
    pathlib.Path
        A path in the same folder that no other call returns (random, not created).

    Examples
    --------
    >>> name = temporary_sibling("/data/sessions/s1").name
    >>> name.startswith(".s1.") and name.endswith(".tmp"), len(name)
    (True, 20)
    """
    path = Path(path)
    return path.with_name(f".{path.name}.{uuid.uuid4().hex[:12]}.tmp")


def fsync_file(path: str | os.PathLike[str]) -> None:
    """Flush a written file's data to disk (errors propagate: the data may not be safe).

    Examples
    --------
    >>> import tempfile
    >>> file = Path(tempfile.mkdtemp()) / "a.bin"
    >>> _ = file.write_bytes(b"frame")
    >>> fsync_file(file)
    """
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def fsync_dir(folder: str | os.PathLike[str]) -> None:
    """Flush a folder's entries (a new file, a rename) to disk where the platform allows it.

    A file created or renamed into a folder is durable only once the folder is synced.
    Platforms and file systems that cannot open or fsync a folder (Windows, some network
    file systems) are skipped silently: the data itself is already synced.

    Examples
    --------
    >>> import tempfile
    >>> fsync_dir(tempfile.mkdtemp())
    """
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def _move_into_place(temporary: Path, path: Path, *, overwrite: bool) -> None:
    if overwrite:
        os.replace(temporary, path)
        return
    try:
        os.link(temporary, path)  # atomic, and fails if path exists
    except FileExistsError:
        raise _exists(path) from None
    except OSError:  # a file system without hard links (e.g. FAT): check, then rename
        if path.exists():
            raise _exists(path) from None
        os.replace(temporary, path)


def _exists(path: Path) -> FileExistsError:
    return FileExistsError(f"{path} already exists and was not replaced (overwrite=False)")


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike[str], *, overwrite: bool) -> Iterator[Path]:
    """Give a temporary path to write ``path`` through; put it in place when the block ends.

    For writers that stream into a file of their own (a MAT file written plane by plane,
    a netCDF library, a zip archive): the block creates and writes the yielded path; on a
    normal exit the file is fsync'd, renamed to ``path`` and the folder fsync'd. If the
    block raises, the temporary file is removed and ``path`` is untouched.

    Parameters
    ----------
    path
        The final file; its folder must exist.
    overwrite
        Replace an existing ``path``. If False, an existing ``path`` (even one that
        appears while the block runs) is never replaced and :class:`FileExistsError` is
        raised.

    Yields
    ------
    pathlib.Path
        The temporary file to create and write (it does not exist yet).

    Raises
    ------
    FileExistsError
        If ``overwrite`` is False and ``path`` exists when the file is put in place.

    Examples
    --------
    >>> import tempfile
    >>> target = Path(tempfile.mkdtemp()) / "cube.txt"
    >>> with atomic_path(target, overwrite=False) as temporary:
    ...     _ = temporary.write_text("cube")
    >>> target.read_text()
    'cube'
    >>> with atomic_path(target, overwrite=False) as temporary:
    ...     _ = temporary.write_text("another cube")
    Traceback (most recent call last):
    ...
    FileExistsError: ... already exists and was not replaced (overwrite=False)
    """
    path = Path(path)
    temporary = temporary_sibling(path)
    try:
        yield temporary
        fsync_file(temporary)
        _move_into_place(temporary, path, overwrite=overwrite)
    finally:
        temporary.unlink(missing_ok=True)
    fsync_dir(path.parent)


def atomic_write_bytes(path: str | os.PathLike[str], data: bytes, *, overwrite: bool) -> Path:
    """Write ``data`` to ``path`` atomically (see :func:`atomic_path`).

    Parameters
    ----------
    path
        The final file; its folder must exist.
    data
        The whole content.
    overwrite
        Replace an existing ``path``; if False, raise :class:`FileExistsError` instead.

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> target = Path(tempfile.mkdtemp()) / "a.bin"
    >>> atomic_write_bytes(target, b"\\x00\\x01", overwrite=False).read_bytes()
    b'\\x00\\x01'
    """
    with atomic_path(path, overwrite=overwrite) as temporary, open(temporary, "xb") as fh:
        fh.write(data)
    return Path(path)


def atomic_write_text(
    path: str | os.PathLike[str], text: str, *, overwrite: bool, encoding: str = "utf-8"
) -> Path:
    """Write ``text`` to ``path`` atomically, encoded with ``encoding`` (UTF-8 by default).

    Parameters
    ----------
    path
        The final file; its folder must exist.
    text
        The whole content (written as is: no newline translation).
    overwrite
        Replace an existing ``path``; if False, raise :class:`FileExistsError` instead.
    encoding
        The text encoding.

    Returns
    -------
    pathlib.Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> target = Path(tempfile.mkdtemp()) / "LATEST"
    >>> atomic_write_text(target, "v0002\\n", overwrite=True).read_text()
    'v0002\\n'
    """
    return atomic_write_bytes(path, text.encode(encoding), overwrite=overwrite)
