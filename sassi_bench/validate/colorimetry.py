"""Colour of reflectance spectra: CIE XYZ, CIELAB, sRGB, CIEDE2000 and spectral metrics.

Colours are computed for CIE illuminant D65 and the CIE 1931 2 degree observer, by 1 nm
weighted sums. A binned spectrum is interpolated linearly between bin centres; outside the
wavelengths it gives (the unusable ends of the band), it is held constant, and the reference
is treated the same way so the comparison only sees the measured band.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "cube_to_srgb",
    "delta_e2000",
    "reflectance_to_lab",
    "reflectance_to_srgb",
    "reflectance_to_xyz",
    "rmse",
    "white_chromaticity",
]

OBSERVER = "CIE 1931 2 Degree Standard Observer"
ILLUMINANT = "D65"
# Pixels per block of cube_to_srgb (a few MB of float32 for a 68-band cube).
_SRGB_BLOCK = 1 << 14


@cache
def _weights() -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """1 nm grid 360-780 nm and the (3, L) XYZ weights (illuminant times CMFs), Y(white) = 1."""
    import colour

    lam = np.arange(360.0, 781.0)
    cmfs = colour.MSDS_CMFS[OBSERVER]
    xyz_bar = np.stack([np.interp(lam, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)])
    d65 = colour.SDS_ILLUMINANTS[ILLUMINANT]
    power = np.interp(lam, d65.wavelengths, d65.values)
    weights = xyz_bar * power
    return lam, weights / weights[1].sum()


def reflectance_to_xyz(wavelengths_nm: ArrayLike, reflectance: ArrayLike) -> NDArray[np.float64]:
    """CIE XYZ (Y of the perfect white = 1) of reflectance spectra under D65.

    Parameters
    ----------
    wavelengths_nm
        (B,) increasing wavelengths of the samples (e.g. the usable bin centres).
    reflectance
        (..., B) reflectance factors.

    Examples
    --------
    >>> xyz = reflectance_to_xyz([400.0, 700.0], [[1.0, 1.0]])
    >>> np.round(xyz, 4).tolist()  # the D65 white point
    [[0.9505, 1.0, 1.0888]]
    """
    lam, weights = _weights()
    src = np.asarray(wavelengths_nm, dtype=np.float64)
    refl = np.asarray(reflectance, dtype=np.float64)
    flat = refl.reshape(-1, src.size)
    # Linear interpolation between samples, constant beyond: a (B, L) matrix.
    idx = np.clip(np.searchsorted(src, lam) - 1, 0, src.size - 2)
    frac = np.clip((lam - src[idx]) / (src[idx + 1] - src[idx]), 0.0, 1.0)
    interp = np.zeros((src.size, lam.size))
    interp[idx, np.arange(lam.size)] += 1.0 - frac
    interp[idx + 1, np.arange(lam.size)] += frac
    xyz = flat @ (interp @ weights.T)
    return xyz.reshape(*refl.shape[:-1], 3)


def white_chromaticity() -> NDArray[np.float64]:
    """The CIELAB white: the illuminant's chromaticity xy for the observer.

    Examples
    --------
    >>> np.round(white_chromaticity(), 4).tolist()
    [0.3127, 0.329]
    """
    import colour

    return np.asarray(colour.CCS_ILLUMINANTS[OBSERVER][ILLUMINANT], dtype=np.float64)


def reflectance_to_lab(wavelengths_nm: ArrayLike, reflectance: ArrayLike) -> NDArray[np.float64]:
    """CIELAB (D65 white) of reflectance spectra.

    Examples
    --------
    >>> np.round(reflectance_to_lab([400.0, 700.0], [0.18, 0.18]), 1).tolist()
    [49.5, 0.0, 0.0]
    """
    import colour

    xyz = reflectance_to_xyz(wavelengths_nm, reflectance)
    return colour.XYZ_to_Lab(xyz, white_chromaticity())


def reflectance_to_srgb(wavelengths_nm: ArrayLike, reflectance: ArrayLike) -> NDArray[np.float64]:
    """Display sRGB (0-1, clipped) of reflectance spectra under D65.

    Examples
    --------
    >>> np.round(reflectance_to_srgb([400.0, 700.0], [1.0, 1.0]), 2).tolist()
    [1.0, 1.0, 1.0]
    """
    import colour

    rgb = colour.XYZ_to_sRGB(reflectance_to_xyz(wavelengths_nm, reflectance))
    return np.clip(rgb, 0.0, 1.0)


def delta_e2000(lab_a: ArrayLike, lab_b: ArrayLike) -> NDArray[np.float64]:
    """CIEDE2000 colour difference.

    Examples
    --------
    >>> float(delta_e2000([50.0, 0.0, 0.0], [50.0, 0.0, 0.0]))
    0.0
    """
    import colour

    return np.asarray(colour.delta_E(lab_a, lab_b, method="CIE 2000"), dtype=np.float64)


def rmse(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Root-mean-square difference along the last axis.

    Examples
    --------
    >>> round(float(rmse([0.1, 0.3], [0.1, 0.2])), 6)
    0.070711
    """
    diff = np.asarray(a, dtype=np.float64) - np.asarray(b, dtype=np.float64)
    return np.sqrt(np.mean(diff**2, axis=-1))


def cube_to_srgb(
    wavelengths_nm: ArrayLike, cube: ArrayLike, usable: ArrayLike | None = None
) -> NDArray[np.float32]:
    """Display sRGB (0-1) of a radiance cube (..., B), scaled so its 99th percentile Y is 1.

    The cube's own light is kept (no illuminant is applied): this is a picture of the scene
    for finding things in it, not a colour measurement. The cube is read in blocks of
    pixels in float32 (NaN counts as 0), so no whole-cube copy is made.

    Parameters
    ----------
    wavelengths_nm
        Band centres (B,).
    cube
        Radiance cube (..., B).
    usable
        Optional mask (...): pixels where it is False count as 0.

    Returns
    -------
    ndarray
        (..., 3) float32 display sRGB.

    Examples
    --------
    >>> cube = np.ones((2, 2, 3))
    >>> cube_to_srgb([450.0, 550.0, 650.0], cube).shape
    (2, 2, 3)
    >>> cube_to_srgb([450.0, 550.0, 650.0], cube, usable=np.eye(2, dtype=bool))[0, 1].tolist()
    [0.0, 0.0, 0.0]
    """
    import colour

    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    cmfs = colour.MSDS_CMFS[OBSERVER]
    weights = np.stack([np.interp(lam, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)])
    weights = weights.T.astype(np.float32)
    cube = np.asarray(cube)
    pixels = cube.reshape(-1, cube.shape[-1])
    keep = None if usable is None else np.asarray(usable, dtype=bool).reshape(-1)
    xyz = np.empty((pixels.shape[0], 3), dtype=np.float32)
    for start in range(0, pixels.shape[0], _SRGB_BLOCK):
        block = slice(start, start + _SRGB_BLOCK)
        part = np.nan_to_num(pixels[block].astype(np.float32))
        if keep is not None:
            part[~keep[block]] = 0.0
        xyz[block] = part @ weights
    scale = float(np.percentile(xyz[:, 1], 99))
    if scale > 0:
        xyz /= np.float32(scale)
    rgb = colour.XYZ_to_sRGB(xyz.reshape(*cube.shape[:-1], 3), apply_cctf_encoding=True)
    return np.clip(rgb, 0.0, 1.0).astype(np.float32)
