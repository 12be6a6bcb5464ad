"""What the spectrum dock shows, without Qt: a pixel's spectrum, a region's mean spectrum
and its spread, and a cube's provenance.

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
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

__all__ = ["RegionSpectrum", "bundle_name", "pixel_spectrum", "provenance_text", "region_spectrum"]


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


@dataclass(frozen=True)
class RegionSpectrum:
    """The spectrum of a region of a cube: per wavelength, the mean and the standard
    deviation over the region's pixels (NaN pixels left out)."""

    wavelengths_nm: NDArray[np.float64]
    mean: NDArray[np.float64]
    std: NDArray[np.float64]
    pixels: int
    """Pixels in the region (inside the cube)."""


def region_spectrum(
    data: Any, metadata: Mapping[str, Any], mask: Any, time_index: int | None = None
) -> RegionSpectrum:
    """The mean spectrum of the pixels of ``mask`` and its standard deviation.

    Parameters
    ----------
    data
        A cube layer's data: ``(wavelength, y, x)``, or ``(time, wavelength, y, x)`` with
        ``time_index`` naming the frame (only that frame is read).
    metadata
        The layer's metadata (``wav``: the bin centres, nm).
    mask
        Boolean ``(y, x)``, the cube's height and width: the region.
    time_index
        The frame of a video (clipped to its frames); ignored for a cube.

    Returns
    -------
    RegionSpectrum
        Empty arrays and 0 pixels when the mask holds no pixel.

    Raises
    ------
    ValueError
        When the mask is not the cube's height and width.

    Examples
    --------
    >>> cube = np.arange(24, dtype=np.float32).reshape(2, 3, 4)  # (wavelength, y, x)
    >>> mask = np.zeros((3, 4), bool)
    >>> mask[1, 1:3] = True  # two pixels: 5 and 6, then 17 and 18
    >>> spectrum = region_spectrum(cube, {"wav": [500.0, 600.0]}, mask)
    >>> spectrum.mean.tolist(), spectrum.std.tolist(), spectrum.pixels
    ([5.5, 17.5], [0.5, 0.5], 2)
    """
    wav = np.asarray(metadata["wav"], dtype=np.float64)
    mask = np.asarray(mask, dtype=bool)
    shape = tuple(int(n) for n in data.shape)
    if mask.shape != shape[-2:]:
        raise ValueError(
            f"the region is {mask.shape} pixels, the cube {shape[-2:]}: draw it on the cube"
        )
    if not mask.any():
        return RegionSpectrum(np.empty(0), np.empty(0), np.empty(0), 0)
    if len(shape) == 4:
        frame = np.asarray(data[int(np.clip(time_index or 0, 0, shape[0] - 1))])
    else:
        frame = np.asarray(data)
    values = frame[:, mask].astype(np.float64)  # (wavelength, pixels)
    finite = np.isfinite(values)
    counts = finite.sum(axis=1)
    safe = np.where(finite, values, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = safe.sum(axis=1) / counts
        std = np.sqrt(np.where(finite, (safe - mean[:, None]) ** 2, 0.0).sum(axis=1) / counts)
    return RegionSpectrum(wav, mean, std, int(mask.sum()))


def bundle_name(metadata: Mapping[str, Any]) -> str | None:
    """``rig/version`` of the bundle a cube layer was extracted with, or None.

    Examples
    --------
    >>> bundle_name({"provenance": {"bundle_rig": "sim", "bundle_version": "v0002"}})
    'sim/v0002'
    """
    found = metadata.get("provenance") or {}
    rig, version = found.get("bundle_rig"), found.get("bundle_version")
    return f"{rig or '?'}/{version or '?'}" if (rig or version) else None


def provenance_text(metadata: Mapping[str, Any], shorten: int | None = None) -> str:
    """The bundle and inputs a cube layer came from, one ``key: value`` a line.

    Parameters
    ----------
    metadata
        The cube layer's metadata (its ``provenance``).
    shorten
        Cut values longer than this many characters (a checksum would widen a dock to its
        length); None keeps them whole.

    Examples
    --------
    >>> print(provenance_text({"provenance": {"bundle_rig": "sim", "bundle_version": "v0002",
    ...                                       "scene": "colorchecker"}}))
    bundle: sim/v0002
    scene: colorchecker
    >>> provenance_text({"provenance": {"session_sha256": "1d65ac35acabd0cd9ae1"}}, shorten=12)
    'session_sha256: 1d65ac35acab…'
    """
    found = dict(metadata.get("provenance") or {})
    lines = []
    bundle = bundle_name(metadata)
    for key in ("bundle_rig", "bundle_version"):
        found.pop(key, None)
    if bundle:
        lines.append(f"bundle: {bundle}")
    for key, value in found.items():
        text = str(value)
        if shorten is not None and len(text) > shorten:
            text = text[:shorten] + "\u2026"
        lines.append(f"{key}: {text}")
    return "\n".join(lines) or "no provenance recorded"
