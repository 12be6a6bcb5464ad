"""The spectral angle: how far apart two spectra are in shape, whatever their brightness."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["spectral_angle_deg"]


def spectral_angle_deg(a: ArrayLike, b: ArrayLike) -> NDArray[np.float64]:
    """Angle in degrees between spectra along the last axis (insensitive to scale); NaN
    where either spectrum is zero.

    Examples
    --------
    >>> round(float(spectral_angle_deg([1.0, 0.0], [1.0, 1.0])), 6)
    45.0
    >>> spectral_angle_deg([[2.0, 2.0], [0.0, 0.0]], [[1.0, 1.0], [1.0, 0.0]]).round(4).tolist()
    [0.0, nan]
    """
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    norms = np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1)
    dot = np.einsum("...b,...b->...", a, b)
    with np.errstate(divide="ignore", invalid="ignore"):
        cos = np.where(norms > 0, dot / norms, np.nan)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
