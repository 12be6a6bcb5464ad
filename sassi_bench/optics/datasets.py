"""The data sets a rig description names, looked up by name.

A rig names its LED and fluorescent lamps (``colour.SDS_ILLUMINANTS``), its guide
camera's sensor (``colour.MSDS_CAMERA_SENSITIVITIES``), the ColorChecker data of the
virtual bench's chart (``colour.SDS_COLOURCHECKERS``) and the photo of its natural scene
(a scikit-image data image). :func:`require_dataset` and :func:`photo_loader` refuse an
unknown name with the key named and the closest known name, so a rig description is
checked when it is loaded rather than when a device first needs the data.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError, did_you_mean, step_error

__all__ = ["DATASETS", "camera_sensitivities", "photo_loader", "require_dataset"]

#: Kind of data -> (colour-science attribute, what one entry is).
DATASETS: dict[str, tuple[str, str]] = {
    "illuminant": ("SDS_ILLUMINANTS", "illuminant"),
    "camera": ("MSDS_CAMERA_SENSITIVITIES", "camera sensitivities"),
    "colourchecker": ("SDS_COLOURCHECKERS", "ColorChecker data"),
}


def require_dataset(kind: str, name: str, key: str) -> Any:
    """The colour-science entry ``name`` of a kind of data; a clear error if unknown.

    Parameters
    ----------
    kind
        ``"illuminant"``, ``"camera"`` or ``"colourchecker"``.
    name
        The name a rig description gives.
    key
        The description's key, named in the error (``"light.led"``).

    Raises
    ------
    ConfigError
        Naming the key, the closest known name and where the names come from.

    Examples
    --------
    >>> require_dataset("illuminant", "LED-B3", "light.led").name
    'LED-B3'
    >>> require_dataset("illuminant", "LED-B33", "light.led")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: light.led: unknown illuminant 'LED-B33' (did you mean ...
    """
    import colour

    attribute, what = DATASETS[kind]
    table = getattr(colour, attribute)
    if name not in table:
        known = sorted(table)
        if kind == "illuminant":  # lamps; the CIE tables also hold daylight series etc.
            known = [k for k in known if k.startswith(("LED", "FL"))]
        raise ConfigError(
            step_error(
                key,
                f"unknown {what} {name!r}{did_you_mean(name, table)}",
                f"use one of colour.{attribute}: {', '.join(known)}",
            )
        )
    return table[name]


def camera_sensitivities(
    name: str, wavelengths_nm: ArrayLike, key: str = "guide_camera.sensitivities"
) -> NDArray[np.float64]:
    """RGB spectral sensitivities (3, L) of a named camera, sampled at ``wavelengths_nm``.

    The names are those of colour-science's camera sensitivity data sets. Peak
    normalised to 1, zero outside the data.

    Raises
    ------
    ConfigError
        If colour-science does not know the camera (the message names ``key``).

    Examples
    --------
    >>> s = camera_sensitivities("Nikon 5100 (NPL)", [450.0, 550.0, 650.0])
    >>> s.shape, int(np.argmax(s[:, 0])), int(np.argmax(s[:, 2]))
    ((3, 3), 2, 0)
    """
    msds = require_dataset("camera", name, key)
    values = np.asarray(msds.values, dtype=np.float64)
    grid = np.asarray(wavelengths_nm, dtype=np.float64)
    out = np.stack(
        [np.interp(grid, msds.wavelengths, values[:, c], left=0.0, right=0.0) for c in range(3)]
    )
    return out / out.max()


def photo_loader(name: str) -> Callable[[], NDArray[np.uint8]]:
    """scikit-image's loader of the data image ``name`` (``scenes.natural_image``).

    Parameters
    ----------
    name
        The name of a function of ``skimage.data``.

    Raises
    ------
    ConfigError
        Naming ``scenes.natural_image`` and the closest data image, if scikit-image has none
        of that name.

    Examples
    --------
    >>> photo_loader("coffee").__name__
    'coffee'
    """
    import skimage.data

    loader = getattr(skimage.data, name, None)
    if loader is None or name.startswith("_") or not callable(loader):
        raise ConfigError(
            step_error(
                "scenes.natural_image",
                f"scikit-image has no data image {name!r}"
                f"{did_you_mean(name, [n for n in dir(skimage.data) if not n.startswith('_')])}",
                "use a bundled colour image such as 'coffee', 'astronaut' or 'chelsea'",
            )
        )
    return loader
