"""Lamp streaks: where a pinhole's atomic lines fall along its streak, as a forward model.

Under a gas-discharge lamp every open SLM pixel draws a streak of separate spots, one
per atomic line, at the columns the dispersion puts the lines' wavelengths. Close lines
blend where the prism's dispersion is coarse (the mercury doublet at 577/579 nm, the
dense neon lines beyond 585 nm), so the lines are not picked as peaks: each pinhole's
streak, summed over its rows, is modelled as the sum of every listed line's spot,

    m_j = gain · Σ_k a_k h(x_j − X_k; σ_k) + background,

with the spot ``h`` of one SLM pixel integrated by a camera pixel (a box of the SLM
pixel's image ⊗ a box of one camera pixel ⊗ the optics' PSF: the blur's profile,
:meth:`~sassi_bench.bundle.blur.GaussianProfile.pixel_spot`), the line amplitudes
``a_k`` shared by every pinhole of a lamp's frames and a gain and background per pinhole
(:mod:`sassi_bench.calibrate.anchored` fits them with the line positions ``X_k``).

:func:`extract_streak_profiles` cuts each pinhole's streak out of a background-free
frame (vectorised gathers; no loop over pinholes).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import nnls

from sassi_bench.bundle import DispersionModel
from sassi_bench.calibrate import _frame_kernels
from sassi_bench.errors import ProcedureError, step_error

__all__ = [
    "StreakProfiles",
    "extract_streak_profiles",
    "shared_line_amplitudes",
    "signal_and_variance",
]


def signal_and_variance(
    lit: NDArray[np.number],
    closed: NDArray[np.number],
    *,
    gain_e_per_adu: float,
    read_noise_e: float,
    dark_adu: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The background-free signal of pinhole frames and its noise variance, per pixel.

    The signal is the mean of the ``lit`` frames minus the mean of the ``closed`` ones
    (the SLM closed under the same light: its leak, stray light and dark signal). A
    pixel's variance grows with its level, ``a + b (level − dark)`` per frame; with two
    or more frames of each kind the line is measured (the variance of frame differences
    against the level, a photon-transfer curve), otherwise it is the camera as described.

    Parameters
    ----------
    lit, closed
        Frames (F, H, W) and (F', H, W), ADU.
    gain_e_per_adu, read_noise_e, dark_adu
        The described camera: electrons per ADU, read noise, dark level.

    Returns
    -------
    signal, variance : ndarray
        (H, W) each, ADU and ADU².

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> level = np.full((2, 64, 64), 400.0)
    >>> lit = rng.poisson(level * 2.0) / 2.0 + 100.0  # 2 e-/ADU, no read noise
    >>> closed = rng.poisson(np.full((2, 64, 64), 200.0)) / 2.0 + 100.0
    >>> signal, variance = signal_and_variance(lit, closed, gain_e_per_adu=2.0, read_noise_e=0.0,
    ...                                        dark_adu=100.0)
    >>> round(float(signal.mean())), bool(abs(variance.mean() - 125.0) < 10)  # (400/2 + 100/2) / 2
    (300, True)
    """
    lit, closed = np.asarray(lit), np.asarray(closed)
    # Per-pixel moments in float64 from the raw frames (no float64 copy of the stacks).
    lit_mean, lit_var = (np.empty(lit.shape[1:]) for _ in range(2))
    closed_mean, closed_var = (np.empty(closed.shape[1:]) for _ in range(2))
    _frame_kernels.frame_moments(lit, lit_mean, lit_var)
    _frame_kernels.frame_moments(closed, closed_mean, closed_var)
    offset, slope = (gain_e_per_adu**-1 * read_noise_e) ** 2, 1.0 / gain_e_per_adu
    if lit.shape[0] >= 2 and closed.shape[0] >= 2:
        levels = np.concatenate([lit_mean.ravel(), closed_mean.ravel()]) - dark_adu
        spread = np.concatenate([lit_var.ravel(), closed_var.ravel()])
        del lit_var, closed_var
        offset, slope = _photon_transfer(levels, spread, offset, slope)

    def per_frame(level):
        return offset + slope * np.clip(level - dark_adu, 0.0, None)

    variance = per_frame(lit_mean) / lit.shape[0] + per_frame(closed_mean) / closed.shape[0]
    return lit_mean - closed_mean, variance


def _photon_transfer(levels, spread, offset, slope) -> tuple[float, float]:
    """A line ``variance = offset + slope · level`` through binned pixel variances (the
    described camera's line when the data cannot tell)."""
    edges = np.unique(np.quantile(levels, np.linspace(0.0, 1.0, 41)))
    which = np.clip(np.searchsorted(edges, levels, side="right") - 1, 0, edges.size - 2)
    counts = np.bincount(which, minlength=edges.size - 1)
    # Hot pixels and cosmic hits: drop the top 0.1 % of the spreads.
    keep = spread <= np.quantile(spread, 0.999)
    sums = np.bincount(which[keep], weights=spread[keep], minlength=edges.size - 1)
    x_sums = np.bincount(which[keep], weights=levels[keep], minlength=edges.size - 1)
    used = np.bincount(which[keep], minlength=edges.size - 1)
    ok = (used > 20) & (counts > 20)
    if ok.sum() < 3:
        return offset, slope
    x, y, w = x_sums[ok] / used[ok], sums[ok] / used[ok], used[ok]
    design = np.column_stack([np.ones_like(x), x]) * np.sqrt(w)[:, None]
    fitted, *_ = np.linalg.lstsq(design, y * np.sqrt(w), rcond=None)
    if fitted[1] <= 0 or fitted[0] <= 0:
        return offset, slope
    return float(fitted[0]), float(fitted[1])


@dataclass(frozen=True, eq=False)
class StreakProfiles:
    """Every pinhole's streak under one lamp, summed over its rows.

    Attributes
    ----------
    light
        The lamp's light name.
    u, v
        SLM column and row of each pinhole (P,).
    columns
        Camera column of every profile sample (P, W).
    profile
        Background-free signal summed over the streak's rows, ADU (P, W).
    variance
        Its noise variance, ADU² (P, W).
    rows
        First and last camera row summed, per pinhole (P, 2).
    """

    light: str
    u: NDArray[np.float64]
    v: NDArray[np.float64]
    columns: NDArray[np.float64]
    profile: NDArray[np.float64]
    variance: NDArray[np.float64]
    rows: NDArray[np.intp]

    @property
    def count(self) -> int:
        """Number of pinholes."""
        return int(self.u.size)

    def select(self, keep: NDArray[np.bool_]) -> StreakProfiles:
        """The profiles of the pinholes ``keep`` marks."""
        return StreakProfiles(
            self.light,
            self.u[keep],
            self.v[keep],
            self.columns[keep],
            self.profile[keep],
            self.variance[keep],
            self.rows[keep],
        )


def extract_streak_profiles(
    signal: NDArray[np.floating],
    model: DispersionModel,
    u: ArrayLike,
    v: ArrayLike,
    band_nm: tuple[float, float],
    reach_px: Callable[[NDArray[np.float64]], NDArray[np.float64]],
    *,
    light: str,
    half_rows: int,
    variance: NDArray[np.floating],
    invalid: NDArray[np.bool_] | None = None,
    margin_px: float = 4.0,
) -> StreakProfiles:
    """Cut every pinhole's streak out of a background-free frame.

    Parameters
    ----------
    signal
        Pinhole frame minus closed-SLM frame, ADU (H, W).
    model
        A dispersion model that places the streaks within ``margin_px`` (the lasers'
        labels are good enough).
    u, v
        The open pixels, SLM column and row.
    band_nm
        The first and last lamp line modelled.
    reach_px
        How far (camera px) a spot reaches beyond its centre, at a wavelength (4 sigma).
    light
        The lamp's light name (recorded).
    half_rows
        Rows summed on each side of the streak's row at 550 nm.
    variance
        The noise variance of ``signal``, ADU² (H, W) (:func:`signal_and_variance`).
    invalid
        Pixels not to trust (saturated); a profile sample summing one gets no weight
        (infinite variance).
    margin_px
        Extra columns on each side for the model's error.

    Returns
    -------
    StreakProfiles
        Pinholes whose window lies inside the camera.

    Raises
    ------
    ProcedureError
        If no pinhole's streak lies inside the camera.

    Examples
    --------
    Not run here (it needs measured frames)::

        profiles = extract_streak_profiles(signal, model, u, v, (404.0, 707.0), reach,
            light="lamp:HgAr", half_rows=10, variance=var)
    """
    u = np.asarray(u, dtype=np.float64).ravel()
    v = np.asarray(v, dtype=np.float64).ravel()
    band = np.asarray(band_nm, dtype=np.float64)
    x_ends, _ = model.evaluate(u[:, None], v[:, None], band[None, :])
    _, y_mid = model.evaluate(u, v, 550.0)
    reach = reach_px(band)
    first = np.floor(x_ends[:, 0] - reach[0] - margin_px).astype(np.intp)
    width = int(np.ceil(np.max(x_ends[:, 1] + reach[1] + margin_px - first))) + 1
    centre = np.rint(y_mid).astype(np.intp)
    height, camera_width = signal.shape
    inside = (first >= 0) & (first + width <= camera_width)
    inside &= (centre - half_rows >= 0) & (centre + half_rows < height)
    if not inside.any():
        raise ProcedureError(
            step_error(
                "lamp streaks",
                "no pinhole's streak lies inside the camera",
                "check the lamp pinhole pitch and the dispersion model",
            )
        )
    first, centre, u, v = first[inside], centre[inside], u[inside], v[inside]
    columns = first[:, None] + np.arange(width)[None, :]
    top, bottom = centre - half_rows, centre + half_rows + 1

    def row_sums(image):
        # Column sums over each pinhole's rows, from a cumulative sum down the columns.
        cumulative = np.vstack(
            [np.zeros((1, camera_width)), np.cumsum(image, axis=0, dtype=np.float64)]
        )
        return cumulative[bottom[:, None], columns] - cumulative[top[:, None], columns]

    profile = row_sums(signal)
    profile_variance = row_sums(variance)
    if invalid is not None:
        profile_variance = np.where(row_sums(invalid) > 0, np.inf, profile_variance)
    return StreakProfiles(
        light=light,
        u=u,
        v=v,
        columns=columns.astype(np.float64),
        profile=profile,
        variance=profile_variance,
        rows=np.stack([top, bottom - 1], axis=1),
    )


def shared_line_amplitudes(scaled: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Non-negative line amplitudes shared by every pinhole of a lamp, by least squares.

    Parameters
    ----------
    scaled
        (P, W, K) each line's weighted spot per pinhole and column, times the pinhole's gain.
    target
        (P, W) each pinhole's weighted streak minus its background.

    Returns
    -------
    numpy.ndarray
        (K,) amplitudes >= 0.

    Examples
    --------
    >>> spots = np.stack([np.eye(3), 2 * np.eye(3)])
    >>> shared_line_amplitudes(spots, spots @ np.array([1.0, 0.0, 2.0])).round(6).tolist()
    [1.0, 0.0, 2.0]
    """
    normal = np.einsum("pjk,pjl->kl", scaled, scaled)
    rhs = np.einsum("pjk,pj->k", scaled, target)
    # A negligible ridge keeps the Cholesky factor defined when a line lights no column.
    ridge = 1e-10 * np.trace(normal) / normal.shape[0] + 1e-300
    chol = np.linalg.cholesky(normal + ridge * np.eye(normal.shape[0]))
    amplitudes, _ = nnls(chol.T, np.linalg.solve(chol, rhs), maxiter=50 * rhs.size)
    return amplitudes
