"""SHA-256 hashing of bundle files, and the ``manifest.sha256`` side file.

``manifest.sha256`` uses the ``sha256sum`` format (``<hex>  manifest.json``), so a bundle can
also be checked without Python: ``cd v0003 && sha256sum -c manifest.sha256``.
"""

from __future__ import annotations

import hashlib
import os
import re

from sassi_bench.bundle.errors import BundleIntegrityError
from sassi_bench.errors import step_error

__all__ = [
    "MANIFEST_CHECKSUM_NAME",
    "MANIFEST_NAME",
    "format_manifest_checksum",
    "parse_manifest_checksum",
    "sha256_bytes",
    "sha256_file",
]

MANIFEST_NAME = "manifest.json"
MANIFEST_CHECKSUM_NAME = "manifest.sha256"

_CHUNK = 1 << 20
_CHECKSUM_LINE = re.compile(r"^([0-9a-f]{64})(?:[ \t]+\*?manifest\.json)?[ \t]*\r?\n?$")


def sha256_bytes(data: bytes) -> str:
    """Hex SHA-256 of ``data``.

    Examples
    --------
    >>> sha256_bytes(b"")[:16]
    'e3b0c44298fc1c14'
    """
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: str | os.PathLike[str]) -> str:
    """Hex SHA-256 of a file, read in 1 MiB chunks.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> p = pathlib.Path(tempfile.mkdtemp()) / "empty"
    >>> _ = p.write_bytes(b"")
    >>> sha256_file(p) == sha256_bytes(b"")
    True
    """
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(_CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def format_manifest_checksum(digest: str) -> str:
    """Content of ``manifest.sha256`` for a manifest with SHA-256 ``digest``.

    Examples
    --------
    >>> format_manifest_checksum("ab" * 32).endswith("  manifest.json\\n")
    True
    """
    return f"{digest}  {MANIFEST_NAME}\n"


def parse_manifest_checksum(text: str) -> str:
    """Read the digest out of ``manifest.sha256``.

    Raises
    ------
    BundleIntegrityError
        If the text is not one ``sha256sum`` line for ``manifest.json``.

    Examples
    --------
    >>> parse_manifest_checksum("ab" * 32 + "  manifest.json\\n") == "ab" * 32
    True
    """
    match = _CHECKSUM_LINE.match(text)
    if match is None:
        raise BundleIntegrityError(
            step_error(
                "bundle verify",
                f"{MANIFEST_CHECKSUM_NAME} is not one line '<64 hex digits>  {MANIFEST_NAME}'",
                "restore the file from a backup or re-import the bundle's zip",
            ),
            file=MANIFEST_CHECKSUM_NAME,
        )
    return match.group(1)
