"""Second moments of lamp-line spots whose weaker neighbours share their streak.

A pinhole under a wavelength lamp makes one spot per atomic line along its streak. Below
the lasers' band the lamp lines are the only narrow light a bench has (HgAr 404.7 and
435.8 nm), so they are where the field blur is measured there. A neighbouring line of the
same lamp sits a few camera px along the streak (Hg 407.8 nm beside 404.7 nm): it
leaves the moments across the streak alone (it lies on the same row) but widens the
windowed moment along it by ``p d²`` for a neighbour of share ``p`` at ``d`` px
(measured: ``docs/notes/2026-11-30-singlet-snapshot-spectra.md``). Along the streak the
spot is therefore fitted instead: the column profile as pixel-integrated Gaussians at
every line within reach, one width, free amplitudes (linear), the width by a grid search,
and one shift of all the lines' columns (the dispersion model can place a line at the
band's end a few tenths of a pixel off, which a fixed centre reads as width). Across
it, and the cross moment, are the windowed moments of
:func:`~sassi_bench.calibrate.blur.measure_spot_widths`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ndtr

from sassi_bench.calibrate.blur import CAMERA_PIXEL_VARIANCE_PX2, measure_spot_widths

__all__ = ["LineSpots", "measure_line_spots"]

#: Widths (camera px) the profile fit searches, and its step.
_SIGMA_GRID = np.arange(0.25, 6.0, 0.005)
#: Shifts (camera px) of the lines' modelled columns the profile fit searches.
_SHIFT_GRID = np.arange(-1.0, 1.0 + 1e-9, 0.01)
#: Changes (camera px) of the width searched once the shift is fitted: a shift of a few
#: tenths of a pixel changes the width by about a tenth.
_SIGMA_NUDGE = np.arange(-0.25, 0.25 + 1e-9, 0.005)


@dataclass(frozen=True)
class LineSpots:
    """Second moments (camera px², camera pixel included) of one line's spots, (N,)."""

    cxx: NDArray[np.float64]
    cyy: NDArray[np.float64]
    cxy: NDArray[np.float64]
    valid: NDArray[np.bool_]


def measure_line_spots(
    signal: ArrayLike,
    x: ArrayLike,
    y: ArrayLike,
    neighbours_x: ArrayLike,
    sigma_guess: float = 1.5,
    saturated: ArrayLike | None = None,
) -> LineSpots:
    """Moments of a line's spots at (x, y), neighbouring lines at ``neighbours_x``.

    Parameters
    ----------
    signal
        Background-free image (pinhole frames less closed-SLM frames), float.
    x, y
        The line's spot centres (camera px), (N,).
    neighbours_x
        (N, K) columns of the same pinholes' other lines (NaN: none); those within the
        profile's reach are fitted with their own amplitude and the line's width.
    sigma_guess
        A rough width for the first moment window.
    saturated
        Boolean image of saturated pixels; spots touching one are invalid.

    Returns
    -------
    LineSpots
        ``cxx`` the fitted profile's variance plus the camera pixel's ``1/12`` (what a
        second moment of an isolated spot measures), ``cyy`` and ``cxy`` the windowed
        moments.

    Examples
    --------
    >>> yy, xx = np.mgrid[0:40, 0:60]
    >>> def spot(cx, a):
    ...     return a * np.exp(-((xx - cx) ** 2 / (2 * 1.2**2) + (yy - 20.2) ** 2 / (2 * 0.9**2)))
    >>> image = spot(25.3, 1.0) + spot(28.4, 0.1)  # a weak neighbour 3.1 px along
    >>> found = measure_line_spots(image, [25.3], [20.2], [[28.4]])
    >>> round(float(np.sqrt(found.cxx[0])), 2), round(float(np.sqrt(found.cyy[0])), 2)
    (1.2, 0.9)
    >>> from sassi_bench.calibrate.blur import measure_spot_widths
    >>> round(float(measure_spot_widths(image, [25.3], [20.2], 1.5).sigma_x[0]), 2)  # widened
    1.46
    """
    image = np.asarray(signal, dtype=np.float64)
    x = np.asarray(x, dtype=np.float64).ravel()
    y = np.asarray(y, dtype=np.float64).ravel()
    others = np.asarray(neighbours_x, dtype=np.float64).reshape(x.size, -1)
    widths = measure_spot_widths(image, x, y, sigma_guess, saturated=saturated)
    sigma_x = _profile_sigma(image, x, y, others, widths)
    valid = widths.valid & np.isfinite(sigma_x)
    cxx = np.where(valid, sigma_x**2 + CAMERA_PIXEL_VARIANCE_PX2, np.nan)
    return LineSpots(cxx, widths.sigma_y**2, widths.cov_xy, valid)


def _profile_sigma(image, x, y, others, widths) -> NDArray[np.float64]:
    """Each spot's width along the streak: its column profile (rows within 3 sigmas of
    the spot's) fitted by Gaussians at its own and its neighbours' columns, all moved by
    one shift fitted with the width."""
    along = np.median(widths.sigma_x[widths.valid]) if widths.valid.any() else 1.5
    across = np.median(widths.sigma_y[widths.valid]) if widths.valid.any() else 1.5
    half = max(3, int(np.ceil(4.5 * along)))
    half_rows = max(2, int(np.ceil(3.0 * across)))
    cx, cy = np.rint(x).astype(np.intp), np.rint(y).astype(np.intp)
    cols = cx[:, None] + np.arange(-half, half + 1)[None, :]  # (N, P)
    rows = cy[:, None] + np.arange(-half_rows, half_rows + 1)[None, :]  # (N, R)
    inside = (cols.min(axis=1) >= 0) & (cols.max(axis=1) < image.shape[1])
    inside &= (rows.min(axis=1) >= 0) & (rows.max(axis=1) < image.shape[0])
    rows_c = np.clip(rows, 0, image.shape[0] - 1)
    cols_c = np.clip(cols, 0, image.shape[1] - 1)
    profile = image[rows_c[:, :, None], cols_c[:, None, :]].sum(axis=1)  # (N, P)
    centres = np.concatenate([x[:, None], others], axis=1)  # (N, K)
    reach = np.abs(centres - cx[:, None]) <= half + 0.5
    reach[:, 0] = True
    centres = np.where(reach & np.isfinite(centres), centres, np.nan)
    left = cols - 0.5  # each column's left edge

    def residual(sigma, shift) -> NDArray[np.float64]:
        """(..., N) residuals at widths and shifts broadcast to (..., N)."""
        shape = np.broadcast_shapes(np.shape(sigma), np.shape(shift), x.shape)
        sigma, shift = np.broadcast_to(sigma, shape), np.broadcast_to(shift, shape)
        return _profile_residual(profile, left, centres + shift[..., None], sigma)

    # The lines' columns come from the dispersion model, which can be a few tenths of a
    # pixel off at the band's ends (docs/notes/2026-11-30-singlet-snapshot-spectra.md);
    # a width fitted about a misplaced centre grows to cover the offset, so the shift is
    # fitted too: the width at no shift, then the shift and the width in turn. The shift
    # is the residual's local minimum nearest none: a neighbour less than a pixel away
    # (Hg 434.7 nm beside 435.8 nm) makes a second one, the two lines' roles swapped.
    chunk = max(1, _GRID_CHUNK_ELEMENTS // max(1, profile.size * centres.shape[1]))
    shift = np.zeros(x.size)
    sigma, ok = _grid_minimum(_SIGMA_GRID, lambda s: residual(s, shift), chunk=chunk)
    for _ in range(2):
        shift, shift_ok = _grid_minimum(
            _SHIFT_GRID, lambda d, s=sigma: residual(s, d), nearest=0.0, chunk=chunk
        )
        nudge, ok = _grid_minimum(
            _SIGMA_NUDGE, lambda c, s=sigma, d=shift: residual(s + c, d), chunk=chunk
        )
        sigma = sigma + nudge
    out = np.full(x.size, np.nan)
    keep = ok & shift_ok & inside
    out[keep] = sigma[keep]
    return out


def _profile_residual(profile, left, centres, sigma) -> NDArray[np.float64]:
    """Squared residual (..., N) of each profile (N, P) against pixel-integrated Gaussians
    of width ``sigma`` (..., N) at ``centres`` (..., N, K; NaN: none), amplitudes fitted
    (linear); the leading axes are trial values, evaluated together."""
    s = sigma[..., None, None]
    edges = left[:, :, None] - centres[..., None, :]  # (..., N, P, K)
    share = np.nan_to_num(ndtr((edges + 1.0) / s) - ndtr(edges / s))
    normal = np.einsum("...npk,...npj->...nkj", share, share) + 1e-12 * np.eye(centres.shape[-1])
    rhs = np.einsum("...npk,np->...nk", share, profile)
    amplitude = np.linalg.solve(normal, rhs[..., None])[..., 0]
    return ((np.einsum("...npk,...nk->...np", share, amplitude) - profile) ** 2).sum(axis=-1)


#: Trial values of a grid search evaluated together, as elements of their (trials, spots,
#: samples, lines) arrays: one call per trial spent its time in numpy's per-call overhead.
_GRID_CHUNK_ELEMENTS = 500_000


def _grid_minimum(
    grid, residual, nearest: float | None = None, chunk: int = 1
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Each spot's minimum of ``residual(values (G, 1)) -> (G, N)`` over ``grid``, ``chunk``
    values a call (the local minimum nearest ``nearest`` if given, else the lowest),
    refined by a parabola through the three nearest values; False where it is at the
    grid's edge."""
    table = np.concatenate(
        [residual(grid[i : i + chunk, None]) for i in range(0, grid.size, chunk)]
    ).T  # (N, G)
    n = table.shape[0]
    best = np.argmin(table, axis=1)
    if nearest is not None:
        local = np.zeros(table.shape, dtype=bool)
        local[:, 1:-1] = (table[:, 1:-1] <= table[:, :-2]) & (table[:, 1:-1] <= table[:, 2:])
        distance = np.where(local, np.abs(grid - nearest)[None, :], np.inf)
        best = np.where(local.any(axis=1), np.argmin(distance, axis=1), best)
    inner = (best > 0) & (best < grid.size - 1)
    i = np.clip(best, 1, grid.size - 2)
    r0, r1, r2 = (table[np.arange(n), i + d] for d in (-1, 0, 1))
    curvature = r0 - 2 * r1 + r2
    step = np.where(curvature > 0, 0.5 * (r0 - r2) / np.where(curvature > 0, curvature, 1), 0)
    return grid[i] + np.clip(step, -1, 1) * (grid[1] - grid[0]), inner
