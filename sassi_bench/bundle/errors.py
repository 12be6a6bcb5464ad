"""Errors raised by the calibration-bundle code.

Every message names the step, the cause and the fix (see :func:`sassi_bench.errors.step_error`).
All of them subclass :class:`BundleError`, itself a :class:`~sassi_bench.errors.SassiBenchError`,
so the command line reports them as user errors and a caller can catch the whole family at once.
"""

from __future__ import annotations

from sassi_bench.errors import SassiBenchError

__all__ = [
    "BundleError",
    "BundleIntegrityError",
    "BundleQualityError",
    "BundleSchemaError",
    "BundleSchemaWarning",
    "UnsafeArchiveError",
    "UnsupportedSchemaError",
]


class BundleError(SassiBenchError):
    """Base class of every calibration-bundle error (not found, refused, invalid...)."""


class BundleIntegrityError(BundleError):
    """A bundle's files do not match their recorded checksums, or files are missing or extra.

    Attributes
    ----------
    file
        The offending file, relative to the bundle folder (``"arrays/response.npy"``), or None.
    """

    def __init__(self, message: str, file: str | None = None) -> None:
        super().__init__(message)
        self.file = file


class BundleSchemaError(BundleError):
    """A manifest does not follow the schema, or a model in it breaks the model contract."""


class UnsupportedSchemaError(BundleSchemaError):
    """The manifest's schema major version is not one this sassi-bench can read."""


class BundleQualityError(BundleError):
    """Publishing was refused because quality checks failed and no override was given."""


class UnsafeArchiveError(BundleIntegrityError):
    """A zip archive holds a path that could escape the bundle folder, or an unexpected entry."""


class BundleSchemaWarning(UserWarning):
    """A bundle was written by a newer (minor) schema than this sassi-bench knows."""
