"""Smooth field models: 2-D Legendre polynomials over the SLM, fitted robustly.

The SLM -> camera map at one wavelength is smooth across the field (relay distortion,
field-dependent dispersion and the skew-ray curvature of a prism are all low order), so
it is fitted as a polynomial in normalised SLM coordinates, the same basis the
calibration bundle uses (:func:`sassi_bench.maths.legendre.legendre2d_design`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.calibrate import _field_kernels
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design, legendre2d_terms

__all__ = ["FieldFit", "evaluate_field", "fit_field"]


def evaluate_field(
    u_hat: ArrayLike, v_hat: ArrayLike, degree: int, coeffs: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``legendre2d_design(u_hat, v_hat, degree) @ coeffs`` without the design matrix.

    The polynomial is ``sum_ij C[i, j] P_i(u) P_j(v)`` with ``C[i, j]`` the coefficient of
    ``P_i(u) P_j(v)``, evaluated point by point by a compiled loop
    (:mod:`~sassi_bench.calibrate._field_kernels`; the design of the prototype's 2 million
    decoded pixels is 340 MB).

    Examples
    --------
    >>> c = np.arange(1.0, 7.0)
    >>> u, v = np.array([0.3, -0.8]), np.array([0.5, 0.1])
    >>> bool(np.allclose(evaluate_field(u, v, 2, c), legendre2d_design(u, v, 2) @ c))
    True
    """
    u_hat, v_hat = np.broadcast_arrays(
        np.asarray(u_hat, dtype=np.float64), np.asarray(v_hat, dtype=np.float64)
    )
    table = np.zeros((degree + 1, degree + 1))
    for (i, j), c in zip(legendre2d_terms(degree), coeffs, strict=True):
        table[i, j] = c
    out = np.empty(u_hat.size)
    _field_kernels.legendre_field(
        np.ascontiguousarray(u_hat).ravel(), np.ascontiguousarray(v_hat).ravel(), table, out
    )
    return out.reshape(u_hat.shape)


@dataclass(frozen=True)
class FieldFit:
    """A robust polynomial fit of one scalar over the SLM field.

    Attributes
    ----------
    coeffs
        Legendre coefficients, ordered as :func:`~sassi_bench.maths.legendre.legendre2d_terms`.
    degree, slm_shape
        Basis degree and the SLM (height, width) defining the normalisation.
    rms, median_abs
        Residual RMS and median absolute residual over the inliers.
    inliers
        Mask of the samples kept by the outlier rejection.
    """

    coeffs: NDArray[np.float64]
    degree: int
    slm_shape: tuple[int, int]
    rms: float
    median_abs: float
    inliers: NDArray[np.bool_]

    def __call__(self, u: ArrayLike, v: ArrayLike) -> NDArray[np.float64]:
        """Evaluate the fit at SLM coordinates (vectorised)."""
        u_hat, v_hat = field_coordinates(u, v, self.slm_shape)
        return evaluate_field(u_hat, v_hat, self.degree, self.coeffs)

    @property
    def n_inliers(self) -> int:
        """Number of samples the fit kept."""
        return int(self.inliers.sum())


def fit_field(
    u: ArrayLike,
    v: ArrayLike,
    values: ArrayLike,
    slm_shape: tuple[int, int],
    degree: int = 5,
    clip_sigmas: float = 4.0,
    max_samples: int = 200_000,
    seed: int = 0,
) -> FieldFit:
    """Fit ``values(u, v)`` with a 2-D Legendre polynomial, rejecting outliers.

    Iterates least squares and rejection of samples further than ``clip_sigmas`` robust
    standard deviations (1.4826 MAD) from the fit until the inlier set is stable. Very
    large sample sets are thinned to ``max_samples`` (seeded) for the solve; residuals
    are reported over all samples.

    Parameters
    ----------
    u, v, values
        Samples (1-D, same length): SLM coordinates and the value there.
    slm_shape
        SLM (height, width).
    degree
        Total degree of the polynomial.

    Returns
    -------
    FieldFit

    Raises
    ------
    ValueError
        With fewer samples than ~3x the number of polynomial terms.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> u, v = rng.uniform(0, 639, 500), rng.uniform(0, 399, 500)
    >>> fit = fit_field(u, v, 3 + 0.01 * u - 2e-5 * v**2, (400, 640), degree=2)
    >>> bool(fit.rms < 1e-9)
    True
    """
    u = np.asarray(u, dtype=np.float64).ravel()
    v = np.asarray(v, dtype=np.float64).ravel()
    values = np.asarray(values, dtype=np.float64).ravel()
    n_terms = (degree + 1) * (degree + 2) // 2
    if not (u.size == v.size == values.size):
        raise ProcedureError(
            step_error(
                "field fit", "u, v and values differ in length", "pass 1-D arrays of equal length"
            )
        )
    if u.size < 3 * n_terms:
        raise ProcedureError(
            step_error(
                "field fit",
                f"{u.size} samples cannot constrain a degree-{degree} polynomial ({n_terms} terms)",
                "capture more valid pixels or lower the field degree",
            )
        )
    u_hat, v_hat = field_coordinates(u, v, slm_shape)
    subset = np.arange(u.size)
    if u.size > max_samples:
        subset = np.sort(np.random.default_rng(seed).choice(u.size, max_samples, replace=False))
    # The design matrix of the solve's samples only (all samples' would be N x terms doubles),
    # solved by its normal equations: the Legendre basis on the unit square keeps them
    # well conditioned, and they cost a tenth of an SVD least squares each round.
    design = legendre2d_design(u_hat[subset], v_hat[subset], degree)
    sampled = values[subset]
    keep = np.ones(subset.size, dtype=bool)
    for _ in range(10):
        kept = design[keep]
        coeffs = _solve_normal(kept.T @ kept, kept.T @ sampled[keep])
        resid = sampled - design @ coeffs
        scale = 1.4826 * np.median(np.abs(resid[keep] - np.median(resid[keep])))
        new_keep = np.abs(resid) <= clip_sigmas * max(scale, 1e-12)
        if np.array_equal(new_keep, keep):
            break
        keep = new_keep
    residual = values - evaluate_field(u_hat, v_hat, degree, coeffs)
    spread = 1.4826 * np.median(np.abs(residual - np.median(residual)))
    inliers = np.abs(residual) <= clip_sigmas * max(spread, 1e-12)
    return FieldFit(
        coeffs=coeffs,
        degree=degree,
        slm_shape=tuple(slm_shape),
        rms=float(np.sqrt(np.mean(residual[inliers] ** 2))),
        median_abs=float(np.median(np.abs(residual[inliers]))),
        inliers=inliers,
    )


def _solve_normal(matrix: NDArray[np.float64], rhs: NDArray[np.float64]) -> NDArray[np.float64]:
    """Least squares from normal equations: Cholesky, else a minimum-norm solve."""
    try:
        factor = np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        return np.linalg.lstsq(matrix, rhs, rcond=None)[0]
    return np.linalg.solve(factor.T, np.linalg.solve(factor, rhs))
