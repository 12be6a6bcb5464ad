"""What the spectrum dock shows, without Qt: a pixel's spectrum and a cube's provenance.

Examples
--------
>>> import numpy as np
>>> cube = np.arange(24, dtype=np.float32).reshape(2, 3, 4)  # (wavelength, y, x)
>>> wav, values = pixel_spectrum(cube, {"wav": [500.0, 600.0]}, (550.0, 1, 2))
>>> wav.tolist(), values.tolist()
([500.0, 600.0], [6.0, 18.0])
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["pixel_spectrum", "provenance_text"]


def pixel_spectrum(
    data: Any, metadata: Mapping[str, Any], position: Sequence[float]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The spectrum of the pixel at ``position`` (data coordinates of a cube layer:
    ``(wavelength, y, x)`` or ``(time, wavelength, y, x)``).

    Returns
    -------
    wavelengths_nm, values : ndarray
        Empty arrays when the position is outside the cube.
    """
    wav = np.asarray(metadata["wav"], dtype=np.float64)
    shape = tuple(int(n) for n in data.shape)
    y, x = (round(float(v)) for v in position[-2:])
    if not (0 <= y < shape[-2] and 0 <= x < shape[-1]):
        return np.empty(0), np.empty(0)
    if len(shape) == 4:
        t = int(np.clip(round(float(position[0])), 0, shape[0] - 1))
        values = np.asarray(data[t, :, y, x], dtype=np.float64)
    else:
        values = np.asarray(data[:, y, x], dtype=np.float64)
    return wav, values


def provenance_text(metadata: Mapping[str, Any]) -> str:
    """The bundle and inputs a cube layer came from, one ``key: value`` a line.

    Examples
    --------
    >>> print(provenance_text({"provenance": {"bundle_rig": "sim", "bundle_version": "v0002",
    ...                                       "scene": "colorchecker"}}))
    bundle: sim/v0002
    scene: colorchecker
    """
    found = dict(metadata.get("provenance") or {})
    lines = []
    rig, version = found.pop("bundle_rig", None), found.pop("bundle_version", None)
    if rig or version:
        lines.append(f"bundle: {rig or '?'}/{version or '?'}")
    lines.extend(f"{key}: {value}" for key, value in found.items())
    return "\n".join(lines) or "no provenance recorded"
