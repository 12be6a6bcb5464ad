"""Publishing from a notebook that may run again: a fit already published is not
published twice, and every publish says which bundle ``latest`` now is."""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ["latest_summary", "publish_guide_once", "publish_once", "publish_spectral_once"]

#: How a manifest's models read in one line.
_MODEL_NAMES = {
    "dispersion": "dispersion",
    "blur": "blur",
    "guide_homography": "guide homography",
    "response": "radiometric response",
}


def _manifest(path: Path) -> dict[str, Any]:
    from sassi_bench.bundle.integrity import MANIFEST_NAME

    try:
        manifest = json.loads((path / MANIFEST_NAME).read_text("utf-8"))
    except (OSError, ValueError):
        return {}
    return manifest if isinstance(manifest, dict) else {}


def _holds(manifest: dict[str, Any]) -> str:
    section = manifest.get("models") or {}
    held = [name for key, name in _MODEL_NAMES.items() if section.get(key)]
    missing = [name for key, name in _MODEL_NAMES.items() if not section.get(key)]
    text = ", ".join(held) or "no models"
    return text + (f"; no {' or '.join(missing)}" if missing else "")


def latest_summary(rig: str, data: str | os.PathLike[str] | None = None) -> str:
    """One line naming the bundle ``latest`` is for ``rig`` and what it holds.

    Examples
    --------
    >>> latest_summary("sim", "/nonexistent")
    'latest: none (sim has no published bundle)'
    """
    from sassi_bench.bundle.layout import latest_version, rig_dir

    folder = rig_dir(rig, data)
    version = latest_version(folder)
    if version is None:
        return f"latest: none ({rig} has no published bundle)"
    manifest = _manifest(folder / version)
    return f"latest: {rig}/{version} ({_holds(manifest)})"


def publish_once(
    models: Any,
    publish: Callable[[], Path],
    *,
    rig: str,
    data: str | os.PathLike[str] | None = None,
) -> Path:
    """Call ``publish`` unless a bundle of ``rig`` already holds exactly ``models``
    (:func:`sassi_bench.bundle.sameness.same_models_version`), and print what happened and
    which bundle ``latest`` now is.

    Parameters
    ----------
    models
        The :class:`~sassi_bench.bundle.CalibrationModels` ``publish`` would publish.
    publish
        Publishes them and returns the new bundle's folder.
    rig
        The rig's folder name under the data root.
    data
        Data root.

    Returns
    -------
    Path
        The new bundle, or the earlier one that already holds these models.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        path = publish_once(result.models(), lambda: publish_spectral(result),
                            rig="sim")
        # not published again: sim/v0001 already holds exactly these models (...)
        # latest: sim/v0003 (dispersion, blur, guide homography, radiometric response)
    """
    from sassi_bench.bundle.layout import rig_dir
    from sassi_bench.bundle.sameness import same_models_version

    earlier = same_models_version(models, rig=rig, data=data)
    if earlier is not None:
        path = rig_dir(rig, data) / earlier
        created = _manifest(path).get("created", "earlier")
        print(
            f"not published again: {rig}/{earlier} already holds exactly these models "
            f"(published {created}); use that bundle"
        )
    else:
        path = Path(publish())
        print(f"published {rig}/{path.name} ({_holds(_manifest(path))}) at {path}")
    print(latest_summary(rig, data))
    return path


def publish_spectral_once(
    result: Any, *, data: str | os.PathLike[str] | None = None, allow_failed: bool = False
) -> Path:
    """:func:`~sassi_bench.reduce.spectral_bundle.publish_spectral`, unless published already
    (:func:`publish_once`).

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        path = publish_spectral_once(result, data="calib_data")
        # published sim/v0001 (dispersion, blur; no guide homography or radiometric response) at ...
        # latest: sim/v0001 (dispersion, blur; no guide homography or radiometric response)
    """
    from sassi_bench.reduce.spectral_bundle import publish_spectral

    return publish_once(
        result.models(),
        lambda: publish_spectral(result, data=data, allow_failed=allow_failed),
        rig=result.rig_description.name,
        data=data,
    )


def publish_guide_once(
    result: Any, bundle: Any, *, data: str | os.PathLike[str] | None = None
) -> Path:
    """:func:`~sassi_bench.reduce.guide.publish_guide` (``bundle``'s models plus the guide
    homography), unless published already (:func:`publish_once`).

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        path = publish_guide_once(result, bundle, data="calib_data")
        # published sim/v0003 (dispersion, blur, guide homography, radiometric response) at ...
        # latest: sim/v0003 (dispersion, blur, guide homography, radiometric response)
    """
    from sassi_bench.reduce.guide import publish_guide

    models = dataclasses.replace(
        bundle.models,
        guide_to_slm=result.homography,
        guide_info={"rms_px": float(result.registration.quality.rms_px)},
    )
    return publish_once(
        models,
        lambda: publish_guide(result, bundle, data=data),
        rig=bundle.rig_name,
        data=data,
    )
