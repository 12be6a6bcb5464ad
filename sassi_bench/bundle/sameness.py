"""Whether a rig already has a bundle holding exactly some models.

Publishing never overwrites, so publishing the same fit twice (a notebook run again, a
chain run after the quick start on the same session) makes a new version whose models
are byte-identical to an earlier one, and moves ``LATEST`` to it: a bundle with a guide
homography can so be displaced by a copy of its own spectral part. A caller that wants to
refuse that asks :func:`same_models_version` first.

Two bundles hold the same models when their manifests' ``models`` sections are equal
(the guide homography's descriptive record aside: the same matrix is the same model) and
every array those sections name has the same SHA-256 (of the ``.npy`` bytes the writer
stores).

Examples
--------
Not run here (it needs a bench, captured sessions or files)::

    same_models_version(result.models(), rig="sim")
    # 'v0001'
"""

from __future__ import annotations

import hashlib
import io
import json
import os
from collections.abc import Mapping
from typing import Any

import numpy as np

from sassi_bench.bundle.integrity import MANIFEST_NAME
from sassi_bench.bundle.jsonio import to_jsonable
from sassi_bench.bundle.layout import rig_dir, version_number, versions
from sassi_bench.bundle.models import CalibrationModels

__all__ = ["model_fingerprint", "same_models_version"]


def _npy_sha256(array: Any) -> str:
    """SHA-256 of an array's ``.npy`` bytes, as the bundle writer stores them."""
    buffer = io.BytesIO()
    np.save(buffer, np.asarray(array), allow_pickle=False)
    return hashlib.sha256(buffer.getvalue()).hexdigest()


def _comparable(section: Mapping[str, Any]) -> dict[str, Any]:
    """A ``models`` section with the guide homography reduced to the array it names."""
    section = dict(section)
    guide = section.get("guide_homography")
    if isinstance(guide, Mapping):
        section["guide_homography"] = {"array": guide.get("array")}
    return section


def model_fingerprint(models: CalibrationModels) -> dict[str, Any]:
    """What makes two bundles' models the same: the comparable ``models`` section and the
    SHA-256 of every array it names.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        fingerprint = model_fingerprint(result.models())
        sorted(fingerprint)
        # ['arrays', 'models']
    """
    section, arrays = models.to_manifest()
    return {
        "models": _comparable(to_jsonable(section, "models", "models")),
        "arrays": {name: _npy_sha256(value) for name, value in arrays.items()},
    }


def _manifest_fingerprint(manifest: Mapping[str, Any], names: Any) -> dict[str, Any] | None:
    section = manifest.get("models")
    stored = manifest.get("arrays")
    if not isinstance(section, Mapping) or not isinstance(stored, Mapping):
        return None
    hashes = {}
    for name in names:
        entry = stored.get(name)
        if not isinstance(entry, Mapping):
            return None
        hashes[name] = entry.get("sha256")
    return {"models": _comparable(section), "arrays": hashes}


def same_models_version(
    models: CalibrationModels, *, rig: str, data: str | os.PathLike[str] | None = None
) -> str | None:
    """The newest published version of ``rig`` whose models are exactly ``models``.

    Manifests are read, not verified (a damaged bundle is the loader's to report); one
    that cannot be read counts as different.

    Parameters
    ----------
    models
        The models about to be published.
    rig
        The rig's folder name under the data root.
    data
        Data root.

    Returns
    -------
    str or None
        ``"v0003"``, or None when no published version holds these models.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        same_models_version(result.models(), rig="sim", data="calib_data")
        # 'v0001'
    """
    wanted = model_fingerprint(models)
    folder = rig_dir(rig, data)
    for version in sorted(versions(folder), key=lambda v: -(version_number(v) or 0)):
        try:
            manifest = json.loads((folder / version / MANIFEST_NAME).read_text("utf-8"))
        except (OSError, ValueError):
            continue
        if not isinstance(manifest, Mapping):
            continue
        if _manifest_fingerprint(manifest, wanted["arrays"]) == wanted:
            return version
    return None
