"""Figures of a scan cube: how well each band is recovered."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["band_psnr_figure"]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


def band_psnr_figure(
    wavelengths_nm: ArrayLike, curves: Mapping[str, ArrayLike]
) -> tuple[Any, dict[str, Any]]:
    """Per-band PSNR of a scan cube, one line per curve.

    Parameters
    ----------
    wavelengths_nm
        (B,) the bins' centres.
    curves
        Label -> (B,) PSNR in dB: the cube against its own propagated noise (any rig),
        against a virtual bench's hidden scene, ...

    Returns
    -------
    figure : matplotlib.figure.Figure
        PSNR against wavelength, with the red end (beyond 650 nm) shaded.
    data : dict
        The wavelengths and each curve.

    Examples
    --------
    >>> fig, data = band_psnr_figure([500.0, 600.0, 680.0], {"noise only": [60.0, 58.0, 55.0]})
    >>> data["noise only"]
    [60.0, 58.0, 55.0]
    """
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    fig = _figure(figsize=(8, 3.8), layout="constrained")
    ax = fig.subplots()
    data: dict[str, Any] = {"wavelength_nm": lam.tolist()}
    for label, curve in curves.items():
        values = np.asarray(curve, dtype=np.float64)
        ax.plot(lam, values, "-o", ms=2.5, label=label)
        data[label] = values.tolist()
    if lam.size and lam.max() > 650:
        ax.axvspan(650, lam.max(), color="0.9", zorder=0, label="red end (> 650 nm)")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("PSNR (dB, cube peak)")
    ax.set_title("Per-band PSNR of the scan cube")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig, data
