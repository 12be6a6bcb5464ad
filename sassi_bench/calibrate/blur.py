"""Blur fit: the width of one SLM pixel's spot on the camera, versus wavelength.

Spot widths are measured on pinhole frames under each laser line, across the
dispersion (along camera rows' normal, i.e. in y), where the laser's own line width
does not widen them. The width is the spot's second moment, so it is the same number a
Gaussian of that sigma would give whatever the exact spot shape. Widths at the lasers
are then fitted with a quadratic in wavelength, as in the SASSI paper.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import BlurModel
from sassi_bench.calibrate.dispersion import LAMBDA_REF_NM, LAMBDA_SCALE_NM
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["BlurFit", "SpotWidths", "fit_blur", "measure_spot_widths"]


@dataclass(frozen=True)
class SpotWidths:
    """Second-moment widths of spots (camera px)."""

    sigma_x: NDArray[np.float64]
    sigma_y: NDArray[np.float64]
    valid: NDArray[np.bool_]

    @property
    def median_sigma_y(self) -> float:
        """Median cross-dispersion width over the valid spots."""
        return float(np.median(self.sigma_y[self.valid]))


def _windows(image: NDArray, x: NDArray, y: NDArray, half: int):
    """Patches (N, 2h+1, 2h+1) around rounded centres; ``inside`` marks full windows."""
    cx = np.rint(x).astype(np.intp)
    cy = np.rint(y).astype(np.intp)
    offsets = np.arange(-half, half + 1)
    rows = cy[:, None, None] + offsets[None, :, None]
    cols = cx[:, None, None] + offsets[None, None, :]
    inside = (cy - half >= 0) & (cy + half < image.shape[0])
    inside &= (cx - half >= 0) & (cx + half < image.shape[1])
    patches = image[np.clip(rows, 0, image.shape[0] - 1), np.clip(cols, 0, image.shape[1] - 1)]
    return patches, rows, cols, inside


def measure_spot_widths(
    signal: ArrayLike,
    x: ArrayLike,
    y: ArrayLike,
    sigma_guess: float,
    saturated: ArrayLike | None = None,
    window_sigmas: float = 4.5,
) -> SpotWidths:
    """Measure the widths of isolated spots at known positions.

    Parameters
    ----------
    signal
        Background-free image (e.g. a pinhole frame minus a closed-SLM frame), float.
    x, y
        Predicted spot centres (camera px), (N,).
    sigma_guess
        Rough width used for the first window; the window is then re-sized once from the
        measured median width.
    saturated
        Boolean image of saturated pixels; spots touching one are invalid.
    window_sigmas
        Half-width of the measurement window in sigmas.

    Returns
    -------
    SpotWidths

    Examples
    --------
    >>> yy, xx = np.mgrid[0:40, 0:40]
    >>> spot = np.exp(-((xx - 20.3) ** 2 + (yy - 19.6) ** 2) / (2 * 1.5**2))
    >>> w = measure_spot_widths(spot, [20.3], [19.6], sigma_guess=1.0)
    >>> round(float(w.sigma_y[0]), 2)
    1.5
    """
    image = np.asarray(signal, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    sigma = float(sigma_guess)
    for _ in range(3):
        half = max(2, int(np.ceil(window_sigmas * sigma)))
        patches, rows, cols, inside = _windows(image, x, y, half)
        total = patches.sum(axis=(1, 2))
        with np.errstate(invalid="ignore", divide="ignore"):
            my = (patches * rows).sum(axis=(1, 2)) / total
            mx = (patches * cols).sum(axis=(1, 2)) / total
            vy = (patches * (rows - my[:, None, None]) ** 2).sum(axis=(1, 2)) / total
            vx = (patches * (cols - mx[:, None, None]) ** 2).sum(axis=(1, 2)) / total
        valid = inside & (total > 0) & (vy > 0) & (vx > 0)
        if saturated is not None:
            sat = np.asarray(saturated, dtype=bool)
            hit = sat[np.clip(rows, 0, sat.shape[0] - 1), np.clip(cols, 0, sat.shape[1] - 1)]
            valid &= ~hit.any(axis=(1, 2))
        if not valid.any():
            raise ProcedureError(
                step_error(
                    "blur measurement",
                    "no spot could be measured (all off the frame, dark or saturated)",
                    "check the pinhole frames' exposure and the laser",
                )
            )
        new_sigma = float(np.median(np.sqrt(vy[valid])))
        if abs(new_sigma - sigma) < 0.02 * sigma:
            break
        sigma = new_sigma
    return SpotWidths(sigma_x=np.sqrt(np.abs(vx)), sigma_y=np.sqrt(np.abs(vy)), valid=valid)


@dataclass(frozen=True)
class BlurFit:
    """Result of :func:`fit_blur`: the model and how well it fits the measurements."""

    model: BlurModel
    wavelengths_nm: NDArray[np.float64]
    measured_sigma_px: NDArray[np.float64]
    residual_px: NDArray[np.float64]

    @property
    def rms_px(self) -> float:
        """RMS of the fit residuals at the measured lines."""
        return float(np.sqrt(np.mean(self.residual_px**2)))


def fit_blur(
    wavelengths_nm: Sequence[float], sigma_px: Sequence[float], window_sigmas: float = 3.0
) -> BlurFit:
    """Fit ``sigma(λ)`` with a quadratic in wavelength.

    Examples
    --------
    >>> fit = fit_blur([405, 450, 520, 635, 670], [1.9, 1.2, 0.7, 1.9, 2.6])
    >>> bool(fit.model.sigma(520.0) < fit.model.sigma(670.0))
    True
    """
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    sig = np.asarray(sigma_px, dtype=np.float64)
    if lam.size < 3:
        raise ProcedureError(
            step_error(
                "blur fit",
                f"only {lam.size} line(s) measured; a quadratic needs three",
                "measure the blur under at least three laser lines",
            )
        )
    t = (lam - LAMBDA_REF_NM) / LAMBDA_SCALE_NM
    coeffs = np.polynomial.polynomial.polyfit(t, sig, 2)
    model = BlurModel(
        tuple(float(c) for c in coeffs), LAMBDA_REF_NM, LAMBDA_SCALE_NM, window_sigmas
    )
    return BlurFit(model, lam, sig, model.sigma(lam) - sig)
