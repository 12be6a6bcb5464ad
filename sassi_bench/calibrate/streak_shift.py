"""How far lamp streaks have moved from where a bundle puts them: the health check's measure.

A bundle's dispersion model predicts, for every open SLM pixel, the column of every lamp
line. Under a lamp each pinhole's streak (:mod:`sassi_bench.calibrate.lamp_streaks`) is
fitted with those predicted columns shifted by one number per pinhole, ``δ_p``,

    m_pj = γ_p Σ_k a_k h(x_j − X_pk − δ_p; σ_k) + β_p,

the line amplitudes ``a_k`` shared by every pinhole (the lamp's spectrum is one), a gain
``γ_p`` and a background ``β_p`` per pinhole. All pinholes are solved together, batched
(no loop over pinholes): the per-pinhole ``(γ, β, δ)`` by Gauss-Newton steps on 3 × 3
systems, the amplitudes by non-negative least squares between steps. The shifts over
the field are then summarised by a smooth map (:func:`shift_field_map`) and turned into
wavelength errors through the bundle's local dispersion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import DispersionModel
from sassi_bench.bundle.blur import GAUSSIAN, GaussianProfile
from sassi_bench.calibrate.lamp_streaks import StreakProfiles, shared_line_amplitudes
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design

__all__ = [
    "ShiftMap",
    "StreakShifts",
    "measure_streak_shifts",
    "row_shifts",
    "shift_field_map",
]


@dataclass(frozen=True, eq=False)
class StreakShifts:
    """Per pinhole, how far its lamp streak lies from the bundle's prediction.

    Attributes
    ----------
    u, v
        SLM column and row of each pinhole (P,).
    dx, dx_sigma
        Shift along the dispersion (camera px, positive = towards longer columns) and its
        1-sigma uncertainty (P,).
    dy
        Shift across the dispersion (camera px): the streak's row centroid minus the
        bundle's (P,); NaN when not measured.
    amplitudes
        The fitted line amplitudes (strongest 1).
    chi2
        Reduced chi-square of the fit.
    """

    u: NDArray[np.float64]
    v: NDArray[np.float64]
    dx: NDArray[np.float64]
    dx_sigma: NDArray[np.float64]
    dy: NDArray[np.float64]
    amplitudes: NDArray[np.float64]
    chi2: float


def measure_streak_shifts(
    profiles: StreakProfiles,
    model: DispersionModel,
    lines_nm: ArrayLike,
    start_intensity: ArrayLike,
    psf_sigma_px: ArrayLike,
    aperture_px: float,
    *,
    iterations: int = 8,
    dy: ArrayLike | None = None,
    spot: GaussianProfile = GAUSSIAN,
) -> StreakShifts:
    """Fit one shift per pinhole of the lamp streaks against a dispersion model.

    Parameters
    ----------
    profiles
        The pinholes' streaks, summed over their rows.
    model
        The bundle's dispersion model (the predicted line columns).
    lines_nm, start_intensity
        The lamp's lines and their table intensities (where the amplitudes start).
    psf_sigma_px
        The optics' PSF sigma at each line (camera px).
    aperture_px
        Side of one SLM pixel's image on the camera (px).
    iterations
        Gauss-Newton rounds.
    dy
        Row shifts measured elsewhere (:func:`row_shifts`), recorded as they are.
    spot
        The spot's profile (the bundle's blur's): a line's pixel-integrated spot.

    Returns
    -------
    StreakShifts

    Raises
    ------
    ProcedureError
        When no listed line is seen in the streaks.

    Examples
    --------
    Not run here (it needs measured frames)::

        shifts = measure_streak_shifts(profiles, bundle.models.dispersion, lines.wavelengths_nm,
            lines.relative_intensity, sigma, 0.93)
        round(float(np.mean(shifts.dx)), 2)
        # 0.0
    """
    lam = np.asarray(lines_nm, dtype=np.float64)
    sigma = np.asarray(psf_sigma_px, dtype=np.float64)
    x_lines, _ = model.evaluate(profiles.u[:, None], profiles.v[:, None], lam[None, :])  # (P, K)
    y = profiles.profile
    weight = np.where(np.isfinite(profiles.variance), 1.0 / np.sqrt(profiles.variance), 0.0)
    count = profiles.count
    shift = np.zeros(count)
    amplitudes = np.asarray(start_intensity, dtype=np.float64)
    amplitudes = amplitudes / amplitudes.max()
    gain = np.ones(count)
    background = np.zeros(count)
    covariance = np.zeros((count, 3, 3))
    for _ in range(iterations):
        offset = profiles.columns[:, :, None] - x_lines[:, None, :] - shift[:, None, None]
        value, slope, _ = spot.pixel_spot(offset, aperture_px, sigma[None, None, :])
        amplitudes = _shared_amplitudes(value, y, weight, gain, background, profiles.light)
        spectrum = value @ amplitudes  # (P, W)
        # d model / d (γ, β, δ), weighted; δ moves every line the same way.
        design = (
            np.stack(
                [spectrum, np.ones_like(spectrum), -gain[:, None] * (slope @ amplitudes)], axis=2
            )
            * weight[:, :, None]
        )
        residual = (y - gain[:, None] * spectrum - background[:, None]) * weight
        normal = np.einsum("pja,pjb->pab", design, design)
        normal += 1e-9 * np.trace(normal, axis1=1, axis2=2)[:, None, None] * np.eye(3)
        covariance = np.linalg.inv(normal)
        step = np.einsum("pab,pjb,pj->pa", covariance, design, residual)
        gain, background = gain + step[:, 0], background + step[:, 1]
        shift = shift + np.clip(step[:, 2], -1.0, 1.0)
    offset = profiles.columns[:, :, None] - x_lines[:, None, :] - shift[:, None, None]
    value = spot.pixel_spot(offset, aperture_px, sigma[None, None, :])[0]
    residual = (y - gain[:, None] * (value @ amplitudes) - background[:, None]) * weight
    dof = max(int(np.count_nonzero(weight)) - 3 * count - lam.size, 1)
    chi2 = float((residual**2).sum() / dof)
    dx_sigma = np.sqrt(np.clip(covariance[:, 2, 2], 0.0, None) * max(chi2, 1.0))
    rows = np.full(count, np.nan) if dy is None else np.asarray(dy, dtype=np.float64)
    return StreakShifts(
        profiles.u, profiles.v, shift, dx_sigma, rows, amplitudes / amplitudes.max(), chi2
    )


def _shared_amplitudes(value, y, weight, gain, background, light) -> NDArray[np.float64]:
    """Non-negative line amplitudes shared by every pinhole, the gains and backgrounds held."""
    scaled = value * (gain[:, None] * weight)[:, :, None]  # (P, W, K)
    target = (y - background[:, None]) * weight
    amplitudes = shared_line_amplitudes(scaled, target)
    if amplitudes.max() <= 0:
        raise ProcedureError(
            step_error(
                f"health check {light}",
                "none of the lamp's listed lines is in its streaks",
                "check that the lamp is on and lights the diffuser, and that the rig's "
                "wavelength_lamps table is the lamp's",
            )
        )
    return amplitudes


def row_shifts(
    signal: NDArray[np.floating], profiles: StreakProfiles, model: DispersionModel, lines_nm
) -> NDArray[np.float64]:
    """Each streak's row centroid minus the bundle's row at its light-weighted wavelength.

    Parameters
    ----------
    signal
        The background-free pinhole frame (H, W), ADU.
    profiles
        The streaks cut from it (their rows and columns).
    model
        The bundle's dispersion model.
    lines_nm
        The lamp lines (their light weights the bundle's rows).

    Returns
    -------
    ndarray
        (P,) camera px.

    Examples
    --------
    Not run here (it needs measured frames)::

        dy = row_shifts(signal, profiles, bundle.models.dispersion, lines)
    """
    top, bottom = profiles.rows[:, 0], profiles.rows[:, 1] + 1
    cols = profiles.columns.astype(np.intp)
    rows = np.arange(signal.shape[0], dtype=np.float64)[:, None]
    zero = np.zeros((1, signal.shape[1]))
    plain = np.vstack([zero, np.cumsum(signal, axis=0, dtype=np.float64)])
    moment = np.vstack([zero, np.cumsum(signal * rows, axis=0, dtype=np.float64)])
    mass = plain[bottom[:, None], cols] - plain[top[:, None], cols]  # (P, W)
    first = moment[bottom[:, None], cols] - moment[top[:, None], cols]
    positive = np.clip(mass, 0.0, None)
    centroid = (first * (mass > 0)).sum(1) / np.maximum(positive.sum(1), 1e-12)
    # The bundle's row at each column's wavelength, weighted like the measurement.
    lam = np.asarray(lines_nm, dtype=np.float64)
    x_lines, y_lines = model.evaluate(profiles.u[:, None], profiles.v[:, None], lam[None, :])
    nearest = np.abs(profiles.columns[:, :, None] - x_lines[:, None, :]).argmin(axis=2)
    predicted = (np.take_along_axis(y_lines, nearest, axis=1) * positive).sum(1)
    return centroid - predicted / np.maximum(positive.sum(1), 1e-12)


@dataclass(frozen=True, eq=False)
class ShiftMap:
    """A smooth map of the shifts over the SLM, and the figures the check prints.

    Attributes
    ----------
    u, v
        Grid of SLM points the map is evaluated on (G,).
    dx
        The map's shift at those points (camera px).
    mean_px, max_px
        Mean and largest absolute shift over the grid.
    wavelength_rms_nm, wavelength_max_nm
        The wavelength error the shift implies over 400-700 nm (shift over the local
        dispersion), RMS and largest.
    coefficients
        Legendre coefficients of the map.
    degree
        Their degree.
    dy
        The map of the shifts across the dispersion at the grid points (camera px).
    sigma_px
        The map's stated 1-sigma along the dispersion, worst over the grid (camera px):
        the weighted fit's covariance from the pinholes' 1-sigmas, scaled by the reduced
        chi-square when the pinholes scatter more than they state.
    """

    u: NDArray[np.float64]
    v: NDArray[np.float64]
    dx: NDArray[np.float64]
    mean_px: float
    max_px: float
    wavelength_rms_nm: float
    wavelength_max_nm: float
    coefficients: NDArray[np.float64]
    degree: int
    dy: NDArray[np.float64]
    sigma_px: float = float("nan")

    @property
    def row_mean_px(self) -> float:
        """Mean shift across the dispersion over the grid (NaN if not measured)."""
        return float(np.mean(self.dy))

    @property
    def row_max_px(self) -> float:
        """Largest absolute shift across the dispersion over the grid."""
        return float(np.max(np.abs(self.dy)))


def shift_field_map(
    shifts: StreakShifts,
    model: DispersionModel,
    *,
    degree: int = 2,
    grid: tuple[int, int] = (17, 11),
) -> ShiftMap:
    """Fit a smooth map to the per-pinhole shifts and summarise it.

    Parameters
    ----------
    shifts
        Per-pinhole shifts.
    model
        The bundle's dispersion model (its SLM shape and local dispersion).
    degree
        Legendre degree of the map (1: offset and tilt; 2 also bends).
    grid
        Field points (columns, rows) the map is summarised on.

    Returns
    -------
    ShiftMap

    Examples
    --------
    Not run here (it needs measured frames)::

        summary = shift_field_map(shifts, bundle.models.dispersion)
        summary.max_px < 0.1
        # True
    """
    shape = model.slm_shape
    good = np.isfinite(shifts.dx) & (shifts.dx_sigma > 0)
    if good.sum() < 10:
        raise ProcedureError(
            step_error(
                "health check",
                f"only {int(good.sum())} pinholes gave a streak position",
                "check that the lamp lights the whole diffuser and re-run the check",
            )
        )
    u, v, dx, coefficients, sigma = _smooth_map(
        shifts.u[good], shifts.v[good], shifts.dx[good], 1.0 / shifts.dx_sigma[good], shape, degree,
        grid,
    )  # fmt: skip
    rows = np.isfinite(shifts.dy)
    dy = (
        _smooth_map(shifts.u[rows], shifts.v[rows], shifts.dy[rows], None, shape, degree, grid)[2]
        if rows.sum() >= 10
        else np.full(u.shape, np.nan)
    )
    lam = np.linspace(400.0, 700.0, 61)
    x, _ = model.evaluate(u[:, None], v[:, None], lam[None, :])
    error_nm = dx[:, None] / np.gradient(x, lam, axis=1)
    return ShiftMap(
        u=u,
        v=v,
        dx=dx,
        mean_px=float(dx.mean()),
        max_px=float(np.abs(dx).max()),
        wavelength_rms_nm=float(np.sqrt(np.mean(error_nm**2))),
        wavelength_max_nm=float(np.abs(error_nm).max()),
        coefficients=coefficients,
        degree=degree,
        dy=dy,
        sigma_px=float(sigma.max()),
    )


def _smooth_map(u, v, values, weights, shape, degree, grid):
    """A Legendre fit of ``values`` over the SLM, evaluated on a ``grid`` of the field,
    with its 1-sigma there (weights are inverse 1-sigmas; the covariance is scaled by the
    reduced chi-square when above one)."""
    design = legendre2d_design(*field_coordinates(u, v, shape), degree)
    w = np.ones_like(values) if weights is None else weights
    weighted = design * w[:, None]
    coefficients = np.linalg.lstsq(weighted, values * w, rcond=None)[0]
    dof = max(values.size - design.shape[1], 1)
    chi2 = float(np.sum((weighted @ coefficients - values * w) ** 2)) / dof
    covariance = np.linalg.pinv(weighted.T @ weighted) * max(chi2, 1.0)
    h, width = shape
    gv, gu = np.meshgrid(
        np.linspace(0, h - 1, grid[1]), np.linspace(0, width - 1, grid[0]), indexing="ij"
    )
    gu, gv = gu.ravel(), gv.ravel()
    at_grid = legendre2d_design(*field_coordinates(gu, gv, shape), degree)
    sigma = np.sqrt(np.clip(np.einsum("gi,ij,gj->g", at_grid, covariance, at_grid), 0.0, None))
    return gu, gv, at_grid @ coefficients, coefficients, sigma
