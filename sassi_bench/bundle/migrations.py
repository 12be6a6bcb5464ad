"""Upgrading manifests written with an older MINOR schema version.

A migration is a pure function ``dict -> dict`` from one minor version to the next, registered
on a :class:`MigrationRegistry`. Loading a bundle verifies the bytes on disk first (checksums
are over the file as written), then migrates the parsed manifest in memory, then validates it
against the current schema; the files are never rewritten.

Examples
--------
>>> registry = MigrationRegistry("1.1.0")
>>> @registry.register("1.0", "1.1")
... def _add_notes(manifest):
...     return {**manifest, "notes": ""}
>>> migrated, old = registry.migrate({"schema_version": "1.0.0"})
>>> migrated["schema_version"], migrated["notes"], old
('1.1.0', '', '1.0.0')
"""

from __future__ import annotations

import copy
import warnings
from collections.abc import Callable
from typing import Any

from sassi_bench.bundle.errors import BundleSchemaWarning, UnsupportedSchemaError
from sassi_bench.bundle.schema import SCHEMA_NAME, SCHEMA_VERSION, parse_semver
from sassi_bench.errors import step_error

__all__ = ["REGISTRY", "Migration", "MigrationRegistry"]

Migration = Callable[[dict[str, Any]], dict[str, Any]]


class MigrationRegistry:
    """Migrations between minor versions of one schema major.

    Parameters
    ----------
    current
        The schema version this code writes, e.g. ``"1.0.0"``.
    """

    def __init__(self, current: str) -> None:
        parsed = parse_semver(current)
        if parsed is None:
            raise ValueError(f"current schema version {current!r} is not MAJOR.MINOR.PATCH")
        self.current = current
        self.major, self.minor, _ = parsed
        self._steps: dict[int, tuple[int, Migration]] = {}

    def register(self, from_version: str, to_version: str) -> Callable[[Migration], Migration]:
        """Decorator registering a migration ``from_version`` -> ``to_version`` (``"1.0"``)."""
        src = _major_minor(from_version)
        dst = _major_minor(to_version)
        if src[0] != self.major or dst[0] != self.major or not src[1] < dst[1] <= self.minor:
            raise ValueError(
                f"a migration must go from an older to a newer minor of major {self.major}, "
                f"up to {self.current}; got {from_version} -> {to_version}"
            )

        def decorator(func: Migration) -> Migration:
            self._steps[src[1]] = (dst[1], func)
            return func

        return decorator

    def migrate(
        self, manifest: dict[str, Any], *, step: str = "bundle load"
    ) -> tuple[dict[str, Any], str | None]:
        """Bring ``manifest`` to the current minor version.

        Parameters
        ----------
        manifest
            A parsed manifest whose ``schema_version`` is a semver string.
        step
            The step named in error messages (e.g. ``"bundle load calib_data/sim/v0003"``).

        Returns
        -------
        manifest, migrated_from
            The (new, deep-copied when migrated) manifest and the version it was migrated from,
            or None when it needed no migration.

        Raises
        ------
        UnsupportedSchemaError
            If the major version differs, or no chain of migrations reaches the current minor.
        """
        found = manifest.get("schema_version")
        parsed = parse_semver(found)
        if parsed is None:
            return manifest, None  # the schema validation reports it
        major, minor, _ = parsed
        if major != self.major:
            raise UnsupportedSchemaError(
                step_error(
                    step,
                    f"the manifest has {SCHEMA_NAME} schema version {found} (major {major}), "
                    f"but this sassi-bench reads schema major {self.major} only "
                    f"(versions {self.major}.0.0 to {self.current})",
                    "upgrade sassi-bench (pip install --upgrade sassi-bench) to a release "
                    f"that reads schema {major}.x"
                    if major > self.major
                    else "re-publish the calibration with this sassi-bench",
                )
            )
        if minor > self.minor:
            warnings.warn(
                f"{step}: the manifest has schema version {found}, newer than {self.current}; "
                "keys added since are ignored. Fix: upgrade sassi-bench to use them",
                BundleSchemaWarning,
                stacklevel=3,
            )
            return manifest, None
        if minor == self.minor:
            return manifest, None
        migrated = copy.deepcopy(manifest)
        while minor < self.minor:
            if minor not in self._steps:
                raise UnsupportedSchemaError(
                    step_error(
                        step,
                        f"no migration from schema version {self.major}.{minor} to {self.current}",
                        "calibrate again with this sassi-bench (or read the bundle with the "
                        "sassi-bench version that published it)",
                    )
                )
            minor, func = self._steps[minor]
            migrated = func(migrated)
            migrated["schema_version"] = f"{self.major}.{minor}.0"
        migrated["schema_version"] = self.current
        return migrated, found


def _major_minor(version: str) -> tuple[int, int]:
    parts = version.split(".")
    if len(parts) not in (2, 3) or not all(part.isdigit() for part in parts):
        raise ValueError(f"version {version!r} is not MAJOR.MINOR")
    return int(parts[0]), int(parts[1])


#: The registry the loader uses. Register migrations here when the schema's minor is bumped.
REGISTRY = MigrationRegistry(SCHEMA_VERSION)


@REGISTRY.register("1.0", "1.1")
def _row_in_wavelength(manifest: dict[str, Any]) -> dict[str, Any]:
    """1.1 added ``models.dispersion.y_index_coeffs`` (the row in the glass index); a 1.0
    bundle has none, so its rows stay the quadratic in wavelength of ``y_coeffs``."""
    return manifest
