"""Streak geometry: where each bin of each open SLM pixel falls on the spectral camera.

:attr:`StreakGeometry.sigma` is the blur *across* the streak at every pixel and bin (the
bundle's blur object's :meth:`~sassi_bench.bundle.blur.BlurModel.spot`), the vertical
spread of the light in each bin's columns, which the row unmixing
(:mod:`~sassi_bench.spectra.cells`), the column fit of dense masks
(:mod:`~sassi_bench.spectra.crosstalk`), the footprints and the noise model use. The
guard bins beyond the band keep the blur of the band's end bin there: their columns hold
mostly the blurred tail of the band's end (on the virtual bench no light lies past 720
nm), whose vertical spread is the end bin's. Giving them the blur at their own
wavelength instead (wider than the rows between stacked pixels at the last guards) made
the row unmixing of those columns ill-conditioned and multiplied the scan's noise
(measured with `benchmarks/accuracy_table.py`: ``docs/notes/2026-11-29-docstring-measurements.md``).

*Along* the streak, where a guard bin is an unknown of the deblur (light at the guard's
own wavelength), its blur is the one at that wavelength: :func:`bin_wavelengths` gives the
wavelength of every bin's column and :func:`clipped_blur` the blur along the streak there,
which the deblur's forward model takes per field point (:mod:`~sassi_bench.spectra.forward`).

"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.blur import GAUSSIAN, GaussianProfile
from sassi_bench.spectra import _kernels

__all__ = [
    "GUARD_BINS",
    "StreakGeometry",
    "bin_wavelengths",
    "clipped_blur",
    "clipped_spot_widths",
    "streak_geometry",
]

GUARD_BINS = 6

#: Wavelength grid (nm) on which the dispersion is inverted for the guard bins.
_INVERSION_GRID_NM = np.linspace(300.0, 1200.0, 9001)


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
        Blur sigma across the streak of each pixel's bins, (N, B + 2 * guard): the guard
        bins carry the band's end bins' (see the module docstring). Given per bin, (B +
        2 * guard,), it is the same for every pixel.
    guard
        Guard bins at each end; the bundle's bins are ``guard .. guard + B``.
    profile
        The blur's profile across the streak (its shares of the cells' rows).
    """

    rows: NDArray[np.intp]
    cols: NDArray[np.intp]
    x_left: NDArray[np.float64]
    x_right: NDArray[np.float64]
    y: NDArray[np.float64]
    sigma: NDArray[np.float64]
    guard: int = GUARD_BINS
    profile: GaussianProfile = field(default=GAUSSIAN, repr=False)

    def __post_init__(self) -> None:
        sigma = np.asarray(self.sigma, dtype=np.float64)
        object.__setattr__(self, "sigma", np.broadcast_to(sigma, np.shape(self.y)))

    @property
    def core(self) -> slice:
        """Index of the bundle's own bins along the bin axis."""
        return slice(self.guard, np.shape(self.y)[1] - self.guard)

    def select(self, keep: NDArray[np.bool_] | NDArray[np.intp]) -> StreakGeometry:
        """The geometry of a subset of the pixels (a mask or indices over N)."""
        return replace(
            self,
            rows=self.rows[keep],
            cols=self.cols[keep],
            x_left=self.x_left[keep],
            x_right=self.x_right[keep],
            y=self.y[keep],
            sigma=self.sigma[keep],
        )

    def shifted(self, camera_rows: float) -> StreakGeometry:
        """The geometry on a crop of the camera whose first row is ``camera_rows``."""
        return replace(self, y=self.y - camera_rows)


def streak_geometry(
    bundle: CalibrationBundle, rows: ArrayLike, cols: ArrayLike, guard: int = GUARD_BINS
) -> StreakGeometry:
    """Bin footprints of open SLM pixels (rows, cols) on the camera, from a bundle.

    Examples
    --------
    >>> geo = streak_geometry(bundle, [200], [320])
    >>> geo.x_left.shape, geo.sigma.shape
    ((1, 80), (1, 80))
    """
    rows = np.asarray(rows, dtype=np.intp).ravel()
    cols = np.asarray(cols, dtype=np.intp).ravel()
    model = bundle.models.dispersion
    # The dispersion model is a polynomial per pixel in a spectral coordinate shared by all
    # pixels, so it is evaluated as the pixels' coefficients (one small product) and a
    # compiled loop that writes every bin once (broadcast numpy evaluation and stacking
    # took most of the geometry's time).
    cx, cy = model.field_coefficients(cols, rows)
    bins = bundle.wavelengths.size
    x_left = np.empty((rows.size, bins + 2 * guard))
    x_right, y = np.empty_like(x_left), np.empty_like(x_left)
    _kernels.streak_bins(
        np.ascontiguousarray(cx.T),
        np.ascontiguousarray(cy.T),
        np.ascontiguousarray(model.spectral_x(bundle.bin_edges), dtype=np.float64),
        np.ascontiguousarray(model.row_coordinate(bundle.wavelengths), dtype=np.float64),
        int(guard),
        x_left,
        x_right,
        y,
    )
    blur = bundle.models.blur
    band = blur.spot(cols[:, None], rows[:, None], bundle.wavelengths[None, :]).across
    if band.ndim == 2 and band.strides[0] == 0:  # the same for every pixel: one row of it
        band = band[:1]
    sigma = np.concatenate(
        [np.repeat(band[:, :1], guard, axis=1), band, np.repeat(band[:, -1:], guard, axis=1)],
        axis=1,
    )
    return StreakGeometry(rows, cols, x_left, x_right, y, sigma, guard, blur.profile)


def bin_wavelengths(bundle: CalibrationBundle, geometry: StreakGeometry) -> NDArray[np.float64]:
    """Centre wavelength of every bin of ``geometry``'s pixels, guard bins included, (N, B').

    The bundle's bins keep their centres; a guard bin's wavelength is where the bundle's
    dispersion model puts the centre of its camera column (the model inverted on a
    0.1 nm grid, 300-1200 nm).

    Examples
    --------
    >>> lam = bin_wavelengths(bundle, streak_geometry(bundle, [200], [320]))
    >>> lam[0, -6:].round(0).tolist()
    [706.0, 718.0, 731.0, 745.0, 759.0, 774.0]
    """
    x, _ = bundle.models.dispersion.evaluate(
        geometry.cols[:, None].astype(float),
        geometry.rows[:, None].astype(float),
        _INVERSION_GRID_NM,
    )
    centres = 0.5 * (geometry.x_left + geometry.x_right)
    lam = np.empty_like(centres)
    for n in range(centres.shape[0]):  # a few dozen field points
        ascending = x[n, -1] > x[n, 0]
        xs = x[n] if ascending else x[n, ::-1]
        grid = _INVERSION_GRID_NM if ascending else _INVERSION_GRID_NM[::-1]
        lam[n] = np.interp(centres[n], xs, grid)
    lam[:, geometry.core] = np.asarray(bundle.wavelengths, dtype=np.float64)
    return lam


def clipped_spot_widths(
    bundle: CalibrationBundle, rows: ArrayLike, cols: ArrayLike, wavelength_nm: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The bundle's blur sigmas along and across the streak (camera px) at SLM pixels
    (rows, cols) and wavelengths (broadcast together), each kept within half the band's
    narrowest and twice its widest blur: outside the band the fitted curve is an
    extrapolation past the lasers, and a fit that bends away there must not give nonsense.

    Examples
    --------
    >>> along, across = clipped_spot_widths(bundle, 200, 320, [550.0, 760.0])
    >>> along.round(2).tolist() == across.round(2).tolist()  # sim's spot is round
    True
    """
    blur = bundle.models.blur
    band = np.asarray(blur.sigma(bundle.wavelengths), dtype=np.float64)
    spot = blur.spot(cols, rows, np.asarray(wavelength_nm, float))
    low, high = 0.5 * np.min(band), 2.0 * np.max(band)
    along = np.clip(np.asarray(spot.along, dtype=np.float64), low, high)
    return along, np.clip(np.asarray(spot.across, dtype=np.float64), low, high)


def clipped_blur(
    bundle: CalibrationBundle, rows: ArrayLike, cols: ArrayLike, wavelength_nm: ArrayLike
) -> NDArray[np.float64]:
    """The bundle's blur sigma along the streak, clipped as :func:`clipped_spot_widths`.

    Examples
    --------
    >>> clipped_blur(bundle, 200, 320, [550.0, 760.0]).round(2).tolist()
    [1.2, 14.07]
    """
    return clipped_spot_widths(bundle, rows, cols, wavelength_nm)[0]


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
    >>> top, bottom = reached_rows(bundle, 512)
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
