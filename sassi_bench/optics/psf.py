"""The relay optics' point-spread width over wavelength, as a rig describes it.

A lab describes the optics' point-spread width at a few wavelengths (Gaussian sigma in
spectral-camera pixels). Through three points the curve is the quadratic the SASSI paper
fits; through more it is a shape-preserving PCHIP interpolant, so a quadratic fit is
an approximation the calibration has to earn. The virtual bench renders its spots with
it, and the capture plans' checks judge streak footprints by it before any calibration;
what the calibration fits and the procedures use is another thing: the bundle's blur
object (:mod:`sassi_bench.bundle.blur`).

What a camera records for one SLM pixel is wider than the optics' PSF: the pixel's
square aperture and the camera pixel's own area add to it. :func:`line_spread_sigma`
gives that total as a moment-matched Gaussian.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator

from sassi_bench.errors import ConfigError

__all__ = ["MIN_SIGMA_PX", "PsfSigmaCurve", "line_spread_sigma"]

MIN_SIGMA_PX = 0.2


class PsfSigmaCurve:
    """Optics PSF sigma as a smooth function of wavelength, through described points.

    Calling it gives the sigma (camera px) at the wavelengths passed, at least
    :data:`MIN_SIGMA_PX`.

    Parameters
    ----------
    sigma_px
        Mapping wavelength (nm) -> Gaussian sigma (camera px), at least three points.

    Raises
    ------
    ConfigError
        On fewer than three points or a sigma <= 0.

    Examples
    --------
    >>> blur = PsfSigmaCurve({405: 1.7, 520: 0.42, 635: 1.7})
    >>> round(float(blur(520.0)), 3)
    0.42
    """

    def __init__(self, sigma_px: Mapping[float, float]) -> None:
        points = sorted((float(k), float(v)) for k, v in sigma_px.items())
        if len(points) < 3:
            raise ConfigError("blur.sigma_px: give the PSF sigma at three or more wavelengths")
        lam = np.array([p[0] for p in points])
        sig = np.array([p[1] for p in points])
        if np.any(sig <= 0):
            raise ConfigError("blur.sigma_px: every sigma must be > 0 px")
        self.points = dict(points)
        if lam.size == 3:
            self._poly = np.polynomial.Polynomial.fit(lam, sig, 2)
            self._pchip = None
        else:
            self._poly = None
            self._pchip = PchipInterpolator(lam, sig, extrapolate=True)

    def __call__(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        lam = np.asarray(wavelength_nm, dtype=np.float64)
        sig = self._poly(lam) if self._poly is not None else self._pchip(lam)
        return np.maximum(sig, MIN_SIGMA_PX)


def line_spread_sigma(
    psf_sigma_px: ArrayLike, slm_pixel_px: float, fill_factor: float = 1.0
) -> NDArray[np.float64]:
    """Sigma of the spot one SLM pixel makes on the camera (moment-matched Gaussian).

    Adds the variances of the optics PSF, the SLM pixel's square aperture (side
    ``fill_factor * slm_pixel_px`` camera px) and the camera pixel (side 1 px).

    Examples
    --------
    >>> round(float(line_spread_sigma(0.0, 1.0, 1.0)), 4)  # two unit boxes
    0.4082
    """
    psf = np.asarray(psf_sigma_px, dtype=np.float64)
    aperture = fill_factor * slm_pixel_px
    return np.sqrt(psf**2 + (aperture**2 + 1.0) / 12.0)
