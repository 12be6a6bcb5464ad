"""Which bundle a command or notebook takes, and why, in words.

``LATEST`` names the newest published bundle of a rig, whatever it holds: a spectral
calibration published on its own (``calibrate spectral``, the quick-start notebook) has
no guide homography and no radiometric response. So ``latest`` means, to a user of a
bundle, *the newest bundle that has what the work needs*: a snapshot (which draws masks
from the guide image) takes the newest bundle with a guide homography, even when a newer
spectral-only one is ``LATEST``. :func:`choose_bundle` makes that choice and says it
(``BundleChoice.reason``); every command prints it. A bundle named explicitly (a
version or a folder) is taken as named, and refused when it lacks what is needed, with
the bundle that has it named. Models that are not needed but change the result (a
response turns counts into radiance) are noted when missing.

Examples
--------
>>> choice = choose_bundle("latest", rig="sim", needs=("guide_homography",))
>>> print(choice.name)
sim/v0001
>>> print(choice.reason)
the newest with a guide -> SLM homography; the latest, sim/v0002, has no guide -> SLM ...
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sassi_bench.bundle.errors import BundleError
from sassi_bench.bundle.integrity import MANIFEST_NAME
from sassi_bench.bundle.layout import (
    normalize_version,
    resolve_bundle_dir,
    resolve_bundle_ref,
    rig_dir,
    version_number,
    versions,
)
from sassi_bench.errors import step_error

__all__ = ["OPTIONAL_MODELS", "BundleChoice", "choose_bundle", "missing_models"]

#: The optional models (keys of a manifest's ``models``): what each is, and the command
#: that adds it to a bundle.
OPTIONAL_MODELS = {
    "guide_homography": ("a guide -> SLM homography", "sassi-bench calibrate guide"),
    "response": ("a radiometric response", "sassi-bench calibrate response"),
}


@dataclass(frozen=True)
class BundleChoice:
    """A bundle and why it was taken.

    Attributes
    ----------
    path
        The bundle folder.
    name
        ``rig/version``.
    reason
        Why this one: ``latest``, the version or folder asked for, or which newer
        bundle lacked what is needed; with notes on models it lacks that would change
        the result.
    """

    path: Path
    name: str
    reason: str

    def __str__(self) -> str:
        return f"{self.name} ({self.reason})"


def missing_models(manifest: Mapping[str, Any], models: Sequence[str]) -> list[str]:
    """Which of ``models`` (keys of :data:`OPTIONAL_MODELS`) a manifest lacks.

    Examples
    --------
    >>> missing_models({"models": {"guide_homography": None, "response": {"array": "response"}}},
    ...                ["guide_homography", "response"])
    ['guide_homography']
    """
    section = manifest.get("models") or {}
    return [name for name in models if not section.get(name)]


def _manifest(path: Path) -> dict[str, Any] | None:
    """A manifest read for choosing (not verified: the loader verifies what is taken)."""
    try:
        manifest = json.loads((path / MANIFEST_NAME).read_text("utf-8"))
    except (OSError, ValueError):
        return None
    return manifest if isinstance(manifest, dict) else None


def _what(models: Sequence[str]) -> str:
    return " and ".join(OPTIONAL_MODELS[m][0] for m in models)


def _none_of(models: Sequence[str]) -> str:
    """``no guide -> SLM homography`` (the article dropped)."""
    return "no " + " and ".join(OPTIONAL_MODELS[m][0].removeprefix("a ") for m in models)


def _name(path: Path, manifest: Mapping[str, Any] | None) -> str:
    if manifest and isinstance(manifest.get("rig_name"), str) and manifest.get("version"):
        return f"{manifest['rig_name']}/{manifest['version']}"
    return str(path)


def _newest_with(folder: Path, models: Sequence[str]) -> tuple[Path, dict[str, Any]] | None:
    for version in sorted(versions(folder), key=lambda v: -(version_number(v) or 0)):
        manifest = _manifest(folder / version)
        if manifest is not None and not missing_models(manifest, models):
            return folder / version, manifest
    return None


def choose_bundle(
    ref: str | os.PathLike[str] | None,
    *,
    rig: str = "sim",
    data: str | os.PathLike[str] | None = None,
    needs: Sequence[str] = (),
    wants: Sequence[str] = (),
    step: str = "bundle",
) -> BundleChoice:
    """The bundle ``ref`` names for work that needs (and would use) some models.

    Parameters
    ----------
    ref
        ``latest`` (or None), a version (``v0003``, ``3``) of ``rig``, or a bundle folder.
    rig
        Rig folder of a version.
    data
        Data root.
    needs
        Models (keys of :data:`OPTIONAL_MODELS`) the work cannot do without: ``latest``
        is the newest bundle that has them; a named bundle without them is refused.
    wants
        Models the work uses when present; their absence is noted in the reason.
    step
        Named in errors.

    Returns
    -------
    BundleChoice

    Raises
    ------
    BundleError
        No bundle, or no bundle with what is needed; a named bundle that lacks it.

    Examples
    --------
    >>> choose_bundle("latest", rig="sim", data="/nonexistent")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.bundle.errors.BundleError: bundle load: no calibration bundle is published ...
    """
    text = "latest" if ref is None else os.fspath(ref)
    try:
        asked_latest = normalize_version(text) == "latest"
    except BundleError:
        asked_latest = False
    if not asked_latest:
        path = resolve_bundle_ref(text, rig=rig, data=data)
        manifest = _manifest(path)
        name = _name(path, manifest)
        lacking = missing_models(manifest or {}, needs)
        if lacking:
            other = _newest_with(path.parent, needs) if manifest else None
            use = (
                f"use {_name(*other)}, which has {'them' if len(lacking) > 1 else 'one'} "
                f"(--bundle {other[1]['version']}), or "
                if other
                else ""
            )
            adds = " and ".join(f"`{OPTIONAL_MODELS[m][1]}`" for m in lacking)
            raise BundleError(
                step_error(
                    step,
                    f"bundle {name} has {_none_of(lacking)}",
                    f"{use}add {'them' if len(lacking) > 1 else 'it'} with {adds} "
                    f"--bundle {path.name} (or run the whole `sassi-bench calibrate`)",
                )
            )
        return BundleChoice(path, name, "as named" + _notes(path.parent, manifest or {}, wants))
    folder = rig_dir(rig, data)
    latest_path = resolve_bundle_dir(rig, "latest", data)  # raises when there is none
    latest = _manifest(latest_path) or {}
    latest_name = _name(latest_path, latest or None)
    if not missing_models(latest, needs):
        return BundleChoice(latest_path, latest_name, "latest" + _notes(folder, latest, wants))
    found = _newest_with(folder, needs)
    if found is None:
        adds = " and ".join(f"`{OPTIONAL_MODELS[m][1]}`" for m in missing_models(latest, needs))
        raise BundleError(
            step_error(
                step,
                f"no bundle of rig {rig!r} has {_what(needs)} (the latest is {latest_name})",
                f"add it with {adds} --bundle {latest_path.name} (or run the whole "
                "`sassi-bench calibrate`)",
            )
        )
    path, manifest = found
    lacks = _none_of(missing_models(latest, needs))
    reason = f"the newest with {_what(needs)}; the latest, {latest_name}, has {lacks}"
    reason += _notes(folder, manifest, wants)
    return BundleChoice(path, _name(path, manifest), reason)


def _notes(folder: Path, manifest: Mapping[str, Any], wants: Sequence[str]) -> str:
    """``; it has no X (sim/v0001 has one)``, and a failed bundle's status."""
    notes = []
    if manifest.get("passed") is False:
        notes.append("it FAILED its quality checks and was published with --allow-failed")
    for model in missing_models(manifest, wants):
        other = _newest_with(folder, [model])
        where = f": {_name(*other)} has one" if other else ""
        notes.append(f"it has {_none_of([model])}{where}")
    return "".join(f"; {note}" for note in notes)
