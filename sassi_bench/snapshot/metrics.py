"""Quality of a reconstructed cube against a reference cube (pure functions on arrays).

All metrics take ``reference`` and ``estimate`` of one shape ``(..., B)`` (bands last) and an
optional ``valid`` mask over the pixels ``(...)`` (e.g. pixels the guide camera sees). The
peak of PSNR is the reference's maximum over the valid pixels and all bands, for every
variant, so per-band values compare with the global one.

PSNR after an affine fit (as the SASSI authors report it): the estimate is first replaced
by ``a * estimate + b`` with ``a, b`` the least-squares fit to the reference, either one
pair for the whole cube (``per_band=False``, the default) or one pair per band; this forgives
a global gain and offset (e.g. an uncalibrated response) but no spatial or spectral error.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import as_float_array, check_shape, check_shape_equality
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.angles import spectral_angle_deg

__all__ = ["affine_fit", "band_psnr", "mean_spectral_angle_deg", "psnr", "ssim"]


def _pair(reference: ArrayLike, estimate: ArrayLike, valid: ArrayLike | None):
    step, fix = "snapshot metrics", "compare cubes of one shape (..., bands)"
    ref = as_float_array(reference, step=step, name="the reference", fix=fix)
    est = as_float_array(estimate, step=step, name="the estimate", fix=fix)
    check_shape_equality(ref, est, step=step, names=("the reference", "the estimate"), fix=fix)
    if ref.ndim < 2:
        raise ProcedureError(
            step_error(step, f"the cubes have shape {ref.shape}, no band axis", fix)
        )
    if valid is None:
        return ref.reshape(-1, ref.shape[-1]), est.reshape(-1, est.shape[-1])
    keep = np.asarray(valid, dtype=bool)
    mask_fix = "pass a boolean mask over the cube's pixels with at least one True"
    check_shape(
        keep,
        ref.shape[:-1],
        step=step,
        name="the valid mask",
        expected_for="the cube's pixels",
        fix=mask_fix,
    )
    if not keep.any():
        raise ProcedureError(step_error(step, "the valid mask selects no pixel", mask_fix))
    return ref[keep], est[keep]


def _psnr(mse, peak):
    with np.errstate(divide="ignore"):
        return 10.0 * np.log10(peak**2 / mse)


def affine_fit(
    reference: ArrayLike, estimate: ArrayLike, *, per_band: bool = False
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Least-squares ``a, b`` with ``a * estimate + b`` closest to ``reference``.

    Both are (P, B) pixels by bands; returns scalars (as 0-d arrays) or (B,) per band.

    Examples
    --------
    >>> est = np.array([[0.0], [1.0], [2.0]])
    >>> [float(v) for v in affine_fit(2 * est + 1, est)]
    [2.0, 1.0]
    """
    ref = np.asarray(reference, dtype=np.float64)
    est = np.asarray(estimate, dtype=np.float64)
    axis = 0 if per_band else None
    mean_e, mean_r = est.mean(axis=axis), ref.mean(axis=axis)
    de = est - mean_e
    var = (de * de).mean(axis=axis)
    cov = (de * (ref - mean_r)).mean(axis=axis)
    a = np.divide(cov, var, out=np.zeros_like(np.asarray(cov)), where=np.asarray(var) > 0)
    return np.asarray(a), np.asarray(mean_r - a * mean_e)


def psnr(
    reference: ArrayLike,
    estimate: ArrayLike,
    *,
    valid: ArrayLike | None = None,
    affine: bool = False,
    per_band_fit: bool = False,
    peak: float | None = None,
) -> float:
    """PSNR in dB over the whole cube, peak = the reference's maximum.

    Parameters
    ----------
    reference, estimate
        Cubes of one shape ``(..., B)``.
    valid
        Pixels to score, ``(...)``; default all.
    affine
        Fit ``a * estimate + b`` to the reference first (see the module docstring).
    per_band_fit
        With ``affine``, one fit per band instead of one for the cube.
    peak
        The peak signal; default the reference's maximum over the scored pixels (give the
        whole cube's peak to score a subset of pixels, e.g. edges, on the same scale).

    Examples
    --------
    >>> ref = np.array([[[1.0, 0.0]]]); est = np.array([[[0.9, 0.1]]])
    >>> round(psnr(ref, est), 3)  # MSE 0.01, peak 1
    20.0
    >>> psnr(ref, 2 * ref + 3, affine=True)
    inf
    >>> round(psnr(ref, est, peak=10.0), 3)
    40.0
    """
    ref, est = _pair(reference, estimate, valid)
    if affine:
        a, b = affine_fit(ref, est, per_band=per_band_fit)
        est = a * est + b
    return float(_psnr(np.mean((est - ref) ** 2), ref.max() if peak is None else peak))


def band_psnr(
    reference: ArrayLike, estimate: ArrayLike, *, valid: ArrayLike | None = None
) -> NDArray[np.float64]:
    """PSNR of each band in dB, (B,), with the cube's peak (so bands compare).

    Examples
    --------
    >>> ref = np.array([[[1.0, 0.5]]]); est = np.array([[[0.9, 0.5]]])
    >>> band_psnr(ref, est).round(3).tolist()
    [20.0, inf]
    """
    ref, est = _pair(reference, estimate, valid)
    return _psnr(np.mean((est - ref) ** 2, axis=0), ref.max())


def ssim(reference: ArrayLike, estimate: ArrayLike) -> float:
    """Mean structural similarity of the cube (scikit-image, bands as channels, 7 x 7
    windows), ``data_range`` = the reference's max minus min.

    Examples
    --------
    >>> ref = np.random.default_rng(0).uniform(size=(16, 16, 3))
    >>> round(ssim(ref, ref), 6), ssim(ref, 0.5 * ref) < 1
    (1.0, True)
    """
    from skimage.metrics import structural_similarity

    ref, est = (np.asarray(x, dtype=np.float64) for x in (reference, estimate))
    _pair(ref, est, None)
    span = float(ref.max() - ref.min())
    return float(structural_similarity(ref, est, channel_axis=-1, data_range=span or 1.0))


def mean_spectral_angle_deg(
    reference: ArrayLike, estimate: ArrayLike, *, valid: ArrayLike | None = None
) -> float:
    """Mean angle in degrees between reference and estimated spectra over the pixels where
    both are non-zero (insensitive to each pixel's brightness).

    Examples
    --------
    >>> round(mean_spectral_angle_deg([[1.0, 0.0], [1.0, 1.0]], [[1.0, 1.0], [2.0, 2.0]]), 4)
    22.5
    """
    ref, est = _pair(reference, estimate, valid)
    angles = spectral_angle_deg(ref, est)
    keep = np.isfinite(angles)
    return float(angles[keep].mean()) if keep.any() else float("nan")
