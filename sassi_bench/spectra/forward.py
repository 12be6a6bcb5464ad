"""The forward model of a streak along its length: how each bin's light reaches the
columns.

Within a streak, bin ``b'``'s light is spread evenly over its camera columns ``[x_left,
x_right]`` and blurred by a Gaussian of the blur at the bin's *own* wavelength; the
fraction of it that lands in bin ``b``'s columns is ``A[b, b']`` (the blur's profile's
:meth:`~sassi_bench.bundle.blur.GaussianProfile.box_overlap`, in closed form). So the
column sums ``a`` of a pixel (what the row unmixing gives,
:mod:`~sassi_bench.spectra.cells`) are ``a = A x`` with ``x`` the light per bin.

The guard bins, one camera pixel each beyond both ends of the band, carry light from
outside the bundle's bins (at the red end of a prism's band, a pixel spans 10-15 nm, so
six guard bins reach 60-90 nm past 700 nm). Their wavelengths come from the bundle's
dispersion model inverted at their columns, and their blur from the bundle's blur model
at those wavelengths: the blur at 700-760 nm is far wider than at the last bin, and a
model that gave the guards the last bin's blur would predict several per cent more light
at the band's end than reaches the camera, which the deblur amplifies.

The spill depends only on the field position, slowly, so it is built at a coarse grid of
field points (:class:`StreakForwardModel`) and each pixel uses its nearest.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.blur import GAUSSIAN, GaussianProfile
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.geometry import (
    GUARD_BINS,
    bin_wavelengths,
    clipped_spot_widths,
    streak_geometry,
)

__all__ = ["FIELD_POINTS", "StreakForwardModel", "guard_wavelengths"]

#: Field points (along u, along v) at which the forward model is evaluated: the spill
#: changes slowly over the field (blending the four nearest points bilinearly changed the
#: ColorChecker cube by 1.4e-4 RMS, relative, at four times the cost of the nearest).
FIELD_POINTS = (9, 6)


def guard_wavelengths(
    bundle: CalibrationBundle, rows: ArrayLike, cols: ArrayLike, guard: int = GUARD_BINS
) -> NDArray[np.float64]:
    """Centre wavelength of every bin of pixels (rows, cols), guard bins included, (N, B').

    The bundle's bins keep their centres; a guard bin's wavelength is where the bundle's
    dispersion model puts the centre of its camera column
    (:func:`~sassi_bench.spectra.geometry.bin_wavelengths`).

    Examples
    --------
    >>> lam = guard_wavelengths(bundle, [200], [320])
    >>> lam[0, :6].round(0).tolist()
    [391.0, 393.0, 394.0, 396.0, 397.0, 399.0]
    >>> lam[0, -6:].round(0).tolist()
    [706.0, 718.0, 731.0, 745.0, 759.0, 774.0]
    """
    return bin_wavelengths(bundle, streak_geometry(bundle, rows, cols, guard))


@dataclass(frozen=True)
class StreakForwardModel:
    """The spill of every bin into every other, at a grid of field points.

    Attributes
    ----------
    grid_u, grid_v
        SLM columns and rows of the field points; point ``p = iv * len(grid_u) + iu``.
    wavelengths_nm
        (P, B') centre wavelength of every bin, guard bins included.
    sigma_px
        (P, B') blur sigma at each bin's own wavelength (camera px).
    spill
        (P, B', B') the share of each bin's light in each bin's columns, at each field
        point.
    guard
        Guard bins at each end; the bundle's bins are ``guard .. B' - guard``.
    spill_error
        (P, B', B') how far the spill may be off: the spill with every blur sigma one
        standard error of the blur fit wider, minus ``spill`` (the bundle's
        ``models.blur.relative_error``); None when the bundle does not state it.
    profile
        The blur's profile (its shares across the streak, for the row unmixing).
    sigma_across_px
        (P, B') blur sigma *across* the streak at each bin's own wavelength (camera px),
        the widths of the sources the row unmixing mixes
        (:mod:`~sassi_bench.spectra.row_mixture`); None: ``sigma_px`` (a round spot).
    """

    grid_u: NDArray[np.float64]
    grid_v: NDArray[np.float64]
    wavelengths_nm: NDArray[np.float64]
    sigma_px: NDArray[np.float64]
    spill: NDArray[np.float64]
    guard: int = GUARD_BINS
    spill_error: NDArray[np.float64] | None = None
    profile: GaussianProfile = field(default=GAUSSIAN, repr=False)
    sigma_across_px: NDArray[np.float64] | None = None

    @classmethod
    def from_bundle(
        cls,
        bundle: CalibrationBundle,
        *,
        points: tuple[int, int] = FIELD_POINTS,
        guard: int = GUARD_BINS,
    ) -> StreakForwardModel:
        """The spill at ``points`` field points, from the bundle's bins, dispersion and blur.

        The blur model is evaluated at every bin's own wavelength, the guards' too (an
        extrapolation of the fitted curve past the lasers; kept within half the band's
        narrowest and twice its widest blur, so a fit that bends away outside the band
        cannot give nonsense).

        Examples
        --------
        >>> model = StreakForwardModel.from_bundle(bundle)
        >>> model.spill.shape
        (54, 80, 80)
        """
        h, w = bundle.slm_shape
        gu = np.linspace(0, w - 1, points[0])
        gv = np.linspace(0, h - 1, points[1])
        vv, uu = np.meshgrid(gv, gu, indexing="ij")
        rows, cols = np.rint(vv.ravel()), np.rint(uu.ravel())
        geo = streak_geometry(bundle, rows, cols, guard)
        lam = guard_wavelengths(bundle, rows, cols, guard)
        blur = bundle.models.blur
        band = np.asarray(blur.sigma(bundle.wavelengths), dtype=np.float64)
        if not (np.all(np.isfinite(band)) and np.all(band > 0)):
            raise ProcedureError(
                step_error(
                    "spectral deblur",
                    f"the bundle's blur widths {band.min():.3g}..{band.max():.3g} px are not "
                    "all positive",
                    "load a bundle whose blur fit passed its checks (sassi-bench bundle verify)",
                )
            )
        # A design's spot is not round (narrower along the streak than across it in
        # places): the row unmixing mixes its sources' widths across the streak
        # (docs/notes/2026-11-30-design-rig-chart-angle.md).
        sigma, across = clipped_spot_widths(bundle, rows[:, None], cols[:, None], lam)
        spill = blur.profile.box_overlap(geo.x_left, geo.x_right, sigma)
        error = blur.relative_error
        spill_error = None
        if error is not None:
            wider = blur.profile.box_overlap(geo.x_left, geo.x_right, sigma * (1.0 + error))
            spill_error = wider - spill
        return cls(gu, gv, lam, sigma, spill, guard, spill_error, blur.profile, across)

    @property
    def row_sigma_px(self) -> NDArray[np.float64]:
        """(P, B') the blur across the streak at each bin's own wavelength (camera px)."""
        return self.sigma_px if self.sigma_across_px is None else self.sigma_across_px

    @property
    def n_bins(self) -> int:
        """B', the bins with guards."""
        return int(self.spill.shape[-1])

    @property
    def core(self) -> slice:
        """Index of the bundle's own bins along the bin axis."""
        return slice(self.guard, self.n_bins - self.guard)

    def point(self, rows: ArrayLike, cols: ArrayLike) -> NDArray[np.intp]:
        """Index of the nearest field point of SLM pixels (rows, cols).

        Examples
        --------
        >>> model = StreakForwardModel(np.array([0.0, 10.0]), np.array([0.0, 4.0]),
        ...                            *(np.zeros((4, 1)),) * 2, np.zeros((4, 1, 1)), 0)
        >>> model.point([0, 4, 3], [2, 9, 6]).tolist()
        [0, 3, 3]
        """
        fv = np.interp(rows, self.grid_v, np.arange(self.grid_v.size))
        fu = np.interp(cols, self.grid_u, np.arange(self.grid_u.size))
        return np.rint(fv).astype(np.intp) * self.grid_u.size + np.rint(fu).astype(np.intp)

    def point_pixels(self) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        """SLM (rows, cols) of every field point, (P,) each."""
        vv, uu = np.meshgrid(self.grid_v, self.grid_u, indexing="ij")
        return np.rint(vv.ravel()).astype(np.intp), np.rint(uu.ravel()).astype(np.intp)
