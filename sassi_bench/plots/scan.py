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


#: Bands whose mean light is under this fraction of the brightest band's are not scored:
#: there the cube's peak over a near-zero noise reads as the best band of the scan.
DARK_BAND_FRACTION = 0.05


def band_psnr_figure(
    wavelengths_nm: ArrayLike,
    curves: Mapping[str, ArrayLike],
    light: ArrayLike | None = None,
) -> tuple[Any, dict[str, Any]]:
    """Per-band PSNR of a scan cube, one line per curve.

    Parameters
    ----------
    wavelengths_nm
        (B,) the bins' centres.
    curves
        Label -> (B,) PSNR in dB: the cube against its own propagated noise (any rig),
        against a virtual bench's hidden scene, ...
    light
        (B,) the cube's mean light per band, or None. Bands under
        :data:`DARK_BAND_FRACTION` of the brightest are shaded and left undrawn.

    Returns
    -------
    figure : matplotlib.figure.Figure
        PSNR against wavelength, with the red end (beyond 650 nm) and the bands without
        light shaded.
    data : dict
        The wavelengths, each curve (None in the bands without light) and the
        ``dark_bands`` mask.

    Examples
    --------
    >>> fig, data = band_psnr_figure(
    ...     [400.0, 500.0, 600.0, 680.0], {"noise only": [106.0, 60.0, 58.0, 55.0]},
    ...     light=[0.001, 1.0, 0.9, 0.5])
    >>> data["noise only"], data["dark_bands"]
    ([None, 60.0, 58.0, 55.0], [True, False, False, False])
    """
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    dark = np.zeros(lam.shape, dtype=bool)
    if light is not None:
        mean_light = np.asarray(light, dtype=np.float64)
        dark = ~(mean_light >= DARK_BAND_FRACTION * np.nanmax(mean_light))
    fig = _figure(figsize=(8, 3.8), layout="constrained")
    ax = fig.subplots()
    data: dict[str, Any] = {"wavelength_nm": lam.tolist(), "dark_bands": dark.tolist()}
    for label, curve in curves.items():
        values = np.where(dark, np.nan, np.asarray(curve, dtype=np.float64))
        ax.plot(lam, values, "-o", ms=2.5, label=label)
        data[label] = [None if np.isnan(v) else float(v) for v in values]
    step = float(np.median(np.diff(lam))) if lam.size > 1 else 1.0
    dark_label = f"under {DARK_BAND_FRACTION:.0%} of the peak light: not scored"
    for i, band in enumerate(np.flatnonzero(dark)):
        ax.axvspan(
            lam[band] - step / 2, lam[band] + step / 2, color="0.75", zorder=0, lw=0,
            label=dark_label if i == 0 else None,
        )  # fmt: skip
    if lam.size and lam.max() > 650:
        ax.axvspan(650, lam.max(), color="0.9", zorder=0, label="red end (> 650 nm)")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("PSNR (dB, cube peak)")
    ax.set_title("Per-band PSNR of the scan cube")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig, data
