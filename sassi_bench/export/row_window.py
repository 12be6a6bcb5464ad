"""The row window of the SASSI authors' extraction, and the share of light it keeps.

``get_cassi_cube`` in the authors' ``modules/cassi.py`` sums ``vsize`` camera rows around
every pixel (``_get_cassi_cube``: ``signal.convolve2d(img, np.ones((vsize, 1)), 'same')``)
and then point-samples that sum with ``cv2.remap`` (bilinear) at each open SLM pixel's
camera position per band. ``vsize`` is one Python integer for all bands. A band's spot is
a Gaussian of the bundle's blur sigma, so the window keeps only part of its light (at
``vsize = 3`` a third of it at the red end of the ``sim`` bench, where sigma is 3.4 px),
and the sample is the light of one camera column, not of a whole bin.

:func:`row_window_share` predicts, per band, the share of the light that the window
keeps (the median over the field, so that a lab can divide the authors' cube by one
number per band), and :func:`nm_per_column` the spectral width of one camera column.
:func:`default_vsize` picks the window: summing more rows keeps more light but also more
noise of their offset estimate (one streak-free pixel's value per camera pixel), and on
dense masks the neighbouring rows' streaks. For a Gaussian spot the share over the square
root of the rows summed peaks at a window of 2.8 sigma; with the share divided out this
is what gave the best spectra on the virtual bench (the export's README.txt has the
numbers).

Examples
--------
>>> default_vsize([0.6, 1.0, 3.4])
3
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["OPTIMAL_WIDTH_SIGMA", "default_vsize", "nm_per_column", "row_window_share"]

#: Box width (in sigma) that maximises a Gaussian spot's share over the square root of
#: the box's width: the window with the best signal against per-row noise.
OPTIMAL_WIDTH_SIGMA = 2.8
#: SLM points per side of the grid over which the per-band medians are taken.
_FIELD_POINTS = 33


def default_vsize(sigma_px: ArrayLike) -> int:
    """The odd row window nearest to 2.8 times the median blur sigma (at least 1).

    Parameters
    ----------
    sigma_px
        The bundle's blur sigma per band, in camera pixels.

    Returns
    -------
    int
        The window ``vsize`` (odd rows).

    Examples
    --------
    >>> default_vsize([1.03]), default_vsize([3.0]), default_vsize([0.2])
    (3, 9, 1)
    """
    sigma = float(np.median(np.asarray(sigma_px, dtype=np.float64)))
    return max(1, 2 * round((OPTIMAL_WIDTH_SIGMA * sigma - 1.0) / 2.0) + 1)


def check_vsize(vsize: int) -> int:
    """``vsize`` as a positive odd int, else a :class:`ProcedureError`.

    An even window is refused: ``convolve2d(..., 'same')`` with an even kernel sums rows
    ``r - vsize/2 .. r + vsize/2 - 1``, half a row off the streak.

    Parameters
    ----------
    vsize
        The window asked for.

    Returns
    -------
    int
        ``vsize`` as a Python int.

    Raises
    ------
    ProcedureError
        If it is not a positive odd whole number.

    Examples
    --------
    >>> check_vsize(5)
    5
    """
    if int(vsize) != vsize or vsize < 1 or vsize % 2 == 0:
        raise ProcedureError(
            step_error(
                "sassi-mat export",
                f"vsize {vsize} is not a positive odd number of rows",
                "pass an odd window (1, 3, 5, ...), or leave it out for the one the blur implies",
            )
        )
    return int(vsize)


def _field(bundle: CalibrationBundle) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    height, width = bundle.slm_shape
    v, u = np.meshgrid(
        np.linspace(0, height - 1, _FIELD_POINTS), np.linspace(0, width - 1, _FIELD_POINTS)
    )
    return u.ravel()[:, None], v.ravel()[:, None]


def row_window_share(
    bundle: CalibrationBundle,
    wavelengths: ArrayLike,
    vsize: int,
    camera_shape: tuple[int, int],
) -> NDArray[np.float64]:
    """Per band, the median over the field of the share of a spot's light that the
    authors' ``vsize``-row sum, sampled bilinearly at the spot's row, contains.

    The spot's rows follow a Gaussian of the bundle's blur sigma (its second moment on
    camera pixels, so the continuous profile has ``sigma**2 - 1/12``); the window sum at
    row ``r`` is the profile's integral over ``r - vsize/2 .. r + vsize/2``, and
    ``cv2.remap`` mixes the two rows around the spot's centre linearly.

    Parameters
    ----------
    bundle
        The calibration bundle.
    wavelengths
        Bands in nm, ``(T,)``.
    vsize
        The window (odd rows).
    camera_shape
        Camera ``(H, W)``: only spots that land on it count.

    Returns
    -------
    ndarray
        ``(T,)`` in (0, 1].

    Examples
    --------
    >>> share = row_window_share(bundle, bundle.wavelengths, 3, (512, 800))  # doctest: +SKIP
    """
    lam = np.atleast_1d(np.asarray(wavelengths, dtype=np.float64))
    vsize = check_vsize(vsize)
    u, v = _field(bundle)
    x, y = bundle.slm_to_camera(u, v, lam[None, :])  # (P, T)
    blur = bundle.models.blur
    sigma = np.asarray(blur.spot(u, v, lam[None, :]).across, dtype=np.float64)  # (P, T)
    s = np.sqrt(np.maximum(sigma**2 - 1.0 / 12.0, 1e-6))
    top = np.floor(y)
    frac = y - top
    cdf = blur.profile.cdf

    def window(row):
        return cdf((row + vsize / 2 - y) / s) - cdf((row - vsize / 2 - y) / s)

    share = (1.0 - frac) * window(top) + frac * window(top + 1.0)
    height, width = camera_shape
    inside = (x >= 0) & (x <= width - 1) & (y >= 0) & (y <= height - 1)
    share[~inside] = np.nan
    return _median_per_band(share, "row window share")


def nm_per_column(
    bundle: CalibrationBundle, wavelengths: ArrayLike, camera_shape: tuple[int, int]
) -> NDArray[np.float64]:
    """Per band, the median over the field of the spectral width (nm) of one camera
    column: what one sample of the authors' cube integrates.

    Parameters
    ----------
    bundle
        The calibration bundle.
    wavelengths
        Bands in nm, ``(T,)``.
    camera_shape
        Camera ``(H, W)``: only points that land on it count.

    Returns
    -------
    ndarray
        ``(T,)`` nm per camera column.

    Examples
    --------
    >>> nm_per_column(bundle, [450.0, 650.0], (512, 800))  # doctest: +SKIP
    array([1.9, 6.2])
    """
    lam = np.atleast_1d(np.asarray(wavelengths, dtype=np.float64))
    u, v = _field(bundle)
    step = 0.5
    x_hi, y = bundle.slm_to_camera(u, v, lam[None, :] + step)
    x_lo, _ = bundle.slm_to_camera(u, v, lam[None, :] - step)
    with np.errstate(divide="ignore"):
        width = 2.0 * step / np.abs(x_hi - x_lo)
    height, camera_width = camera_shape
    inside = (x_lo >= 0) & (x_hi <= camera_width - 1) & (y >= 0) & (y <= height - 1)
    width[~inside] = np.nan
    return _median_per_band(width, "nm per column")


def _median_per_band(values: NDArray[np.float64], what: str) -> NDArray[np.float64]:
    if np.isnan(values).all(axis=0).any():
        raise ProcedureError(
            step_error(
                "sassi-mat export",
                f"no SLM point lands on the camera in some band, so its {what} is unknown",
                "check that the bundle belongs to this camera (camera_shape) and its bands",
            )
        )
    return np.nanmedian(values, axis=0)
