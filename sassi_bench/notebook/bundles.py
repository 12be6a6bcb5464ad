"""The bundle a notebook works with, chosen as the commands choose it, and said."""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any

__all__ = ["bundle_for"]


def bundle_for(
    rig: Any,
    version: str | os.PathLike[str] = "latest",
    data: str | os.PathLike[str] | None = None,
    *,
    needs: Sequence[str] = (),
    wants: Sequence[str] = (),
) -> Any:
    """Load the bundle ``version`` names for ``rig`` and print which one it is and why
    (:func:`sassi_bench.bundle.choice.choose_bundle`: ``latest`` is the newest bundle
    that has the models the notebook ``needs``).

    Parameters
    ----------
    rig
        The rig (its name is the bundles' folder).
    version
        ``latest``, a version (``v0003``) or a bundle folder.
    data
        Data root.
    needs, wants
        Models the notebook cannot do without, and models it uses when there
        (``guide_homography``, ``response``).

    Returns
    -------
    CalibrationBundle

    Examples
    --------
    Not run here (it needs a notebook and a rig)::

        bundle = bundle_for(rig, needs=("guide_homography",))
        # bundle: sim/v0001 (the newest with a guide -> SLM homography; the latest, ...)
    """
    from sassi_bench.bundle import load
    from sassi_bench.bundle.choice import choose_bundle

    choice = choose_bundle(
        version, rig=rig.description.name, data=data, needs=needs, wants=wants, step="notebook"
    )
    print(f"bundle: {choice}")
    return load(choice.path)
