"""Dispersion fit: where every SLM pixel's light of every wavelength lands.

Input: per-laser smooth maps ``(u, v) -> (x, y)`` (:class:`LaserMap`). Output: the
bundle's dispersion model, in which camera column ``x`` is a quadratic in the prism
glass's refractive index ``n(λ)`` and camera row ``y`` a quadratic in ``λ``, with every
coefficient a smooth (Legendre) function of the SLM field:

    x(u, v, λ) = Σ_k Σ_t a_kt P_t(û, v̂) s_x(λ)^k,   s_x = (n(λ) − n_ref) / n_scale
    y(u, v, λ) = Σ_k Σ_t b_kt P_t(û, v̂) s_y(λ)^k,   s_y = (λ − 550 nm) / 150 nm

The honest accuracy figure is the leave-one-laser-out error: refit without one laser
and predict where that laser's light lands.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle.models import (
    DispersionModel,
    WavelengthBins,
    field_coordinates,
    legendre2d_design,
)
from sassi_bench.calibrate.field import FieldFit
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.optics.glass import Glass, get_glass

__all__ = ["DispersionFit", "LaserMap", "fit_dispersion", "wavelength_bins"]

LAMBDA_REF_NM = 550.0
LAMBDA_SCALE_NM = 150.0
BAND_NM = (400.0, 700.0)


@dataclass(frozen=True)
class LaserMap:
    """The smooth SLM -> camera map measured under one laser line."""

    wavelength_nm: float
    x: FieldFit
    y: FieldFit
    n_correspondences: int
    counts: dict[str, int] = field(default_factory=dict)


@dataclass(frozen=True)
class DispersionFit:
    """Result of :func:`fit_dispersion`.

    Attributes
    ----------
    model
        The bundle's :class:`~sassi_bench.bundle.models.DispersionModel`.
    bins
        Wavelength bins, one per camera column of the 400-700 nm streak at the field centre.
    residual_px
        Per laser, RMS (x, y) distance between the joint model and that laser's own map.
    leave_one_out
        Per laser, the error predicting it from the others: ``rms_px``, ``max_px`` (2-D
        distance over the field) and ``rms_nm`` (column error over the local dispersion).
    position_sigma_px
        Largest 1-sigma uncertainty of the predicted column at the field centre over
        400-700 nm, propagated from the least-squares covariance.
    """

    model: DispersionModel
    bins: WavelengthBins
    residual_px: dict[float, float]
    leave_one_out: dict[float, dict[str, float]]
    position_sigma_px: float

    @property
    def leave_one_out_rms_px(self) -> float:
        """RMS over lasers of the leave-one-laser-out position error."""
        values = [entry["rms_px"] for entry in self.leave_one_out.values()]
        return float(np.sqrt(np.mean(np.square(values)))) if values else float("nan")

    @property
    def leave_one_out_rms_nm(self) -> float:
        """RMS over lasers of the leave-one-laser-out wavelength error."""
        values = [entry["rms_nm"] for entry in self.leave_one_out.values()]
        return float(np.sqrt(np.mean(np.square(values)))) if values else float("nan")


def _grid(slm_shape: tuple[int, int], points: tuple[int, int]) -> tuple[NDArray, NDArray]:
    h, w = slm_shape
    v, u = np.meshgrid(
        np.linspace(0, h - 1, points[1]), np.linspace(0, w - 1, points[0]), indexing="ij"
    )
    return u.ravel(), v.ravel()


def _spectral_design(s: NDArray[np.float64], field_design: NDArray[np.float64], order: int):
    """Rows (laser, grid point) x columns (power k, field term t), k-major like the bundle."""
    powers = s[:, None] ** np.arange(order + 1)[None, :]  # (L, K)
    return np.einsum("lk,gt->lgkt", powers, field_design).reshape(
        s.size * field_design.shape[0], -1
    )


def _solve(design, values):
    coeffs, *_ = np.linalg.lstsq(design, values, rcond=None)
    return coeffs


def fit_dispersion(
    maps: Sequence[LaserMap],
    glass: str | Glass,
    slm_shape: tuple[int, int],
    field_degree: int = 5,
    order: int = 2,
    grid: tuple[int, int] = (33, 21),
) -> DispersionFit:
    """Fit the joint dispersion model to per-laser maps.

    Parameters
    ----------
    maps
        One :class:`LaserMap` per laser line (at least ``order + 1`` lines; one more for
        the leave-one-laser-out error).
    glass
        The prism glass (its Sellmeier index defines ``s_x``).
    slm_shape
        SLM (height, width).
    field_degree, order
        Legendre degree of the coefficient fields; polynomial order in ``s``.
    grid
        Field points (columns, rows) at which the per-laser maps are compared.

    Returns
    -------
    DispersionFit

    Raises
    ------
    ValueError
        With too few laser lines or duplicated wavelengths.
    """
    g = glass if isinstance(glass, Glass) else get_glass(glass)
    lam = np.array([m.wavelength_nm for m in maps], dtype=np.float64)
    if lam.size < order + 1:
        raise ProcedureError(
            step_error(
                "dispersion fit",
                f"{lam.size} laser line(s) cannot fix a degree-{order} dispersion model",
                f"measure at least {order + 1} lines (the procedure's lasers_nm)",
            )
        )
    if np.unique(lam).size != lam.size:
        raise ProcedureError(
            step_error("dispersion fit", "a laser wavelength appears twice", "list each line once")
        )
    n_ref = float(g.index(LAMBDA_REF_NM))
    n_scale = float(g.index(BAND_NM[0]) - g.index(BAND_NM[1]))
    u, v = _grid(slm_shape, grid)
    field_design = legendre2d_design(*field_coordinates(u, v, slm_shape), field_degree)
    xs = np.stack([m.x(u, v) for m in maps])  # (L, G)
    ys = np.stack([m.y(u, v) for m in maps])
    sx = (g.index(lam) - n_ref) / n_scale
    sy = (lam - LAMBDA_REF_NM) / LAMBDA_SCALE_NM

    def fit(keep: NDArray[np.bool_]):
        ax = _solve(_spectral_design(sx[keep], field_design, order), xs[keep].ravel())
        ay = _solve(_spectral_design(sy[keep], field_design, order), ys[keep].ravel())
        return ax.reshape(order + 1, -1), ay.reshape(order + 1, -1)

    def model_from(ax, ay) -> DispersionModel:
        return DispersionModel(
            glass=g.name,
            sellmeier_b=g.b,
            sellmeier_c=g.c,
            n_ref=n_ref,
            n_scale=n_scale,
            lambda_ref_nm=LAMBDA_REF_NM,
            lambda_scale_nm=LAMBDA_SCALE_NM,
            slm_shape=tuple(slm_shape),
            field_degree=field_degree,
            x_coeffs=ax,
            y_coeffs=ay,
        )

    everything = np.ones(lam.size, dtype=bool)
    model = model_from(*fit(everything))
    px, py = model.evaluate(u[None, :], v[None, :], lam[:, None])
    residual = {
        float(lam[i]): float(np.sqrt(np.mean((px[i] - xs[i]) ** 2 + (py[i] - ys[i]) ** 2)))
        for i in range(lam.size)
    }
    leave_one_out: dict[float, dict[str, float]] = {}
    if lam.size > order + 1:
        for i in range(lam.size):
            keep = everything.copy()
            keep[i] = False
            partial = model_from(*fit(keep))
            qx, qy = partial.evaluate(u, v, lam[i])
            dist = np.hypot(qx - xs[i], qy - ys[i])
            dx_dlam = _dispersion_px_per_nm(model, u, v, lam[i])
            leave_one_out[float(lam[i])] = {
                "rms_px": float(np.sqrt(np.mean(dist**2))),
                "max_px": float(dist.max()),
                "rms_nm": float(np.sqrt(np.mean(((qx - xs[i]) / dx_dlam) ** 2))),
            }
    sigma = _centre_position_sigma(model, sx, xs, field_design, order, slm_shape)
    return DispersionFit(
        model=model,
        bins=wavelength_bins(model),
        residual_px=residual,
        leave_one_out=leave_one_out,
        position_sigma_px=sigma,
    )


def _dispersion_px_per_nm(model: DispersionModel, u, v, wavelength_nm: float) -> NDArray:
    step = 0.05
    lo, _ = model.evaluate(u, v, wavelength_nm - step)
    hi, _ = model.evaluate(u, v, wavelength_nm + step)
    return (hi - lo) / (2 * step)


def _centre_position_sigma(model, sx, xs, field_design, order, slm_shape) -> float:
    """Largest 1-sigma column uncertainty at the field centre over the band."""
    design = _spectral_design(sx, field_design, order)
    coeffs = model.x_coeffs.ravel()
    resid = xs.ravel() - design @ coeffs
    dof = max(design.shape[0] - design.shape[1], 1)
    cov = np.linalg.pinv(design.T @ design) * float(resid @ resid) / dof
    h, w = slm_shape
    centre = legendre2d_design(
        *field_coordinates((w - 1) / 2, (h - 1) / 2, slm_shape), model.field_degree
    )
    lam = np.linspace(*BAND_NM, 31)
    s = model.spectral_x(lam)
    rows = (s[:, None] ** np.arange(order + 1)[None, :])[:, :, None] * centre[None, None, :]
    rows = rows.reshape(lam.size, -1)
    return float(np.sqrt(np.max(np.einsum("ij,jk,ik->i", rows, cov, rows))))


def wavelength_bins(
    model: DispersionModel, band_nm: tuple[float, float] = BAND_NM
) -> WavelengthBins:
    """One wavelength bin per camera column of the streak at the field centre.

    The bin centred on camera column ``k`` spans columns ``k - 1/2 .. k + 1/2``; columns
    run from the first at or after the ``band_nm[0]`` end of the centre pixel's streak to
    the last at or before its ``band_nm[1]`` end.

    Examples
    --------
    >>> import numpy as np
    >>> x = np.zeros((3, 1)); x[0, 0] = 400.0; x[1, 0] = -60.0
    >>> m = DispersionModel("N-BK7", (1.03961212, 0.231792344, 1.01046945),
    ...                     (0.00600069867, 0.0200179144, 103.560653), 1.5185, 0.0178,
    ...                     550.0, 150.0, (400, 640), 0, x, np.zeros((3, 1)))
    >>> bins = wavelength_bins(m)
    >>> bins.count, bool(np.all(np.diff(bins.edges_nm) > 0))
    (60, True)
    """
    h, w = model.slm_shape
    lam = np.linspace(band_nm[0] - 30.0, band_nm[1] + 30.0, 36001)
    x, _ = model.evaluate((w - 1) / 2, (h - 1) / 2, lam)
    if np.any(np.diff(x) <= 0):
        raise ProcedureError(
            step_error(
                "wavelength bins",
                "the fitted streak is not monotonic in wavelength at the field centre",
                "check the laser wavelengths and the sweep decoding",
            )
        )
    x_lo, x_hi = np.interp(band_nm, lam, x)
    columns = np.arange(np.ceil(x_lo), np.floor(x_hi) + 1)
    centres = np.interp(columns, x, lam)
    edges = np.interp(np.append(columns - 0.5, columns[-1] + 0.5), x, lam)
    return WavelengthBins(centres_nm=centres, edges_nm=edges, resolution_nm=np.diff(edges))
