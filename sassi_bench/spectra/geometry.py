"""Streak geometry: where each bin of each open SLM pixel falls on the spectral camera."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.spectra import _kernels

__all__ = ["GUARD_BINS", "StreakGeometry", "streak_geometry"]

GUARD_BINS = 6


@dataclass(frozen=True)
class StreakGeometry:
    """Where the bins (with guard bins at both ends) of open pixels fall on the camera.

    Attributes
    ----------
    rows, cols
        SLM coordinates of the open pixels, (N,).
    x_left, x_right
        Camera columns bounding each bin, (N, B + 2 * guard).
    y
        Camera row of each bin's centre, (N, B + 2 * guard).
    sigma
        Blur sigma of each bin, (B + 2 * guard,).
    guard
        Guard bins at each end; the bundle's bins are ``guard .. guard + B``.
    """

    rows: NDArray[np.intp]
    cols: NDArray[np.intp]
    x_left: NDArray[np.float64]
    x_right: NDArray[np.float64]
    y: NDArray[np.float64]
    sigma: NDArray[np.float64]
    guard: int = GUARD_BINS

    @property
    def core(self) -> slice:
        """Index of the bundle's own bins along the bin axis."""
        return slice(self.guard, self.sigma.size - self.guard)

    def select(self, keep: NDArray[np.bool_] | NDArray[np.intp]) -> StreakGeometry:
        """The geometry of a subset of the pixels (a mask or indices over N)."""
        return replace(
            self,
            rows=self.rows[keep],
            cols=self.cols[keep],
            x_left=self.x_left[keep],
            x_right=self.x_right[keep],
            y=self.y[keep],
        )

    def shifted(self, camera_rows: float) -> StreakGeometry:
        """The geometry on a crop of the camera whose first row is ``camera_rows``."""
        return replace(self, y=self.y - camera_rows)


def streak_geometry(
    bundle: CalibrationBundle, rows: ArrayLike, cols: ArrayLike, guard: int = GUARD_BINS
) -> StreakGeometry:
    """Bin footprints of open SLM pixels (rows, cols) on the camera, from a bundle."""
    rows = np.asarray(rows, dtype=np.intp).ravel()
    cols = np.asarray(cols, dtype=np.intp).ravel()
    model = bundle.models.dispersion
    # The dispersion model is a polynomial per pixel in a spectral coordinate shared by all
    # pixels, so it is evaluated as the pixels' coefficients (one small product) and a
    # compiled loop that writes every bin once (broadcast numpy evaluation and stacking
    # took 5 ms of the 6 for a prototype frame).
    cx, cy = model.field_coefficients(cols, rows)
    bins = bundle.wavelengths.size
    x_left = np.empty((rows.size, bins + 2 * guard))
    x_right, y = np.empty_like(x_left), np.empty_like(x_left)
    _kernels.streak_bins(
        np.ascontiguousarray(cx.T),
        np.ascontiguousarray(cy.T),
        np.ascontiguousarray(model.spectral_x(bundle.bin_edges), dtype=np.float64),
        np.ascontiguousarray(model.spectral_y(bundle.wavelengths), dtype=np.float64),
        int(guard),
        x_left,
        x_right,
        y,
    )
    sigma = np.asarray(bundle.blur_width(bundle.wavelengths), dtype=np.float64)
    return StreakGeometry(
        rows=rows,
        cols=cols,
        x_left=x_left,
        x_right=x_right,
        y=y,
        sigma=np.concatenate([np.full(guard, sigma[0]), sigma, np.full(guard, sigma[-1])]),
        guard=guard,
    )


def reached_rows(
    bundle: CalibrationBundle,
    camera_height: int,
    reach_sigmas: float = 3.0,
    margin_px: float = 3.0,
    guard: int = GUARD_BINS,
) -> tuple[int, int]:
    """First and one-past-last camera row that light of any SLM pixel can reach.

    Streaks are sampled densely along the SLM's border (where a smooth map takes its
    extremes) and on a coarse interior grid, widened by ``reach_sigmas`` of the widest
    blur and ``margin_px``, and clipped to the camera.

    Examples
    --------
    >>> top, bottom = reached_rows(bundle, 512)  # doctest: +SKIP
    """
    h, w = bundle.slm_shape
    edge_u, edge_v = np.linspace(0, w - 1, 65), np.linspace(0, h - 1, 65)
    grid_v, grid_u = np.meshgrid(np.linspace(0, h - 1, 17), np.linspace(0, w - 1, 17))
    u = np.concatenate([edge_u, edge_u, np.zeros(65), np.full(65, w - 1), grid_u.ravel()])
    v = np.concatenate([np.zeros(65), np.full(65, h - 1), edge_v, edge_v, grid_v.ravel()])
    geo = streak_geometry(bundle, np.rint(v), np.rint(u), guard)
    reach = reach_sigmas * geo.sigma.max() + margin_px
    top = int(np.clip(np.floor(geo.y.min() - reach), 0, camera_height))
    bottom = int(np.clip(np.ceil(geo.y.max() + reach) + 1, 0, camera_height))
    return top, bottom
