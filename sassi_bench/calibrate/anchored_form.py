"""How far the lamp-anchored column misses optics its form can only approximate.

The anchored fit (:mod:`sassi_bench.calibrate.anchored`) weighs its data by their
information: the lamp lines where they are dense and narrow, the lasers at their few
wavelengths. Where the column's form (a polynomial in the glass index at each field
point) cannot follow the optics exactly, that weighting decides where the misfit lands,
and it lands where the data are thin: often the band's red end, where lamp lines blend.
There the fit misses the optics by more than an unweighted fit of the same form would
(:func:`~sassi_bench.reduce.lamps.described_form_misfit_nm`), with no noise at all, and
the photon noise the fit states says nothing of it.

:func:`anchored_form_error_px` measures that miss on optics the caller supplies (a rig's
described optics: never the bench's as built): it renders every laser map and lamp
streak the fit used, noise-free, through those optics, with the fit's own spot widths,
amplitudes, gains and backgrounds, fits them exactly as the data were fitted, and
returns the fitted column's RMS distance from the optics over the field at every
wavelength of the band. The dispersion fit adds it to the map's stated uncertainty.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from sassi_bench.calibrate.anchored import (
    AnchoredWavelengths,
    LampStreaks,
    _Spectral,
    fit_anchored_wavelengths,
)
from sassi_bench.calibrate.dispersion import BAND_NM
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design
from sassi_bench.optics.glass import Glass

__all__ = ["BAND_SAMPLES", "ColumnOptics", "anchored_form_error_px"]

#: Wavelengths over the band the error is given at (as the dispersion fit's stated 1-sigma).
BAND_SAMPLES = 31
#: Field points (columns, rows) the error's RMS is taken over.
_FIELD_GRID = (17, 11)

#: Camera column of SLM points at wavelengths, broadcasting: ``column(u, v, lam) -> x``.
ColumnOptics = Callable[[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]], NDArray]


@dataclass(frozen=True)
class _TracedMap:
    """A laser map traced through the optics (what :func:`fit_anchored_wavelengths` reads
    of a :class:`~sassi_bench.calibrate.dispersion.LaserMap`)."""

    wavelength_nm: float
    column: ColumnOptics

    def x(self, u: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
        return np.asarray(self.column(u, v, np.full(np.shape(u), self.wavelength_nm)))


def _traced_streaks(data: LampStreaks, fit: AnchoredWavelengths, column: ColumnOptics):
    """The lamp's streaks as the fit models them, with every line where the optics put it."""
    p = data.profiles
    lamp = fit.lamps[data.name]
    positions = np.asarray(column(p.u[:, None], p.v[:, None], data.lines_nm[None, :]))
    sigma = lamp.psf_sigma_px(data.lines_nm)
    offset = p.columns[:, :, None] - positions[:, None, :]
    spots = data.spot.pixel_spot(offset, data.aperture_px, np.broadcast_to(sigma, offset.shape))[0]
    profile = lamp.gains[:, None] * (spots @ lamp.amplitudes) + lamp.backgrounds[:, None]
    return replace(data, psf_sigma_px=sigma, profiles=replace(p, profile=profile))


def anchored_form_error_px(
    fit: AnchoredWavelengths,
    lamps: Sequence[LampStreaks],
    glass: Glass,
    slm_shape: tuple[int, int],
    tolerance_nm: Sequence[float],
    column: ColumnOptics,
    *,
    field_degree: int = 5,
    order: int = 2,
) -> NDArray[np.float64]:
    """The anchored fit's column error on ``column``'s optics with no noise, camera px.

    Every laser map (at ``fit``'s wavelengths, each its own label) and lamp streak (the
    fit's spot widths, amplitudes, gains and backgrounds, the lines where ``column`` puts
    them, the streaks' own noise for weights) is made noise-free through ``column`` and
    fitted as ``fit`` was; the result is the fitted column's RMS distance from
    ``column`` over the field, at each of :data:`BAND_SAMPLES` wavelengths over 400-700 nm.

    Parameters
    ----------
    fit
        The anchored fit whose form error is wanted.
    lamps
        The lamp streaks it was fitted to (their pinholes, windows and noise are kept).
    glass, slm_shape, field_degree, order
        As the fit was made.
    tolerance_nm
        Per laser, the prior's sigma the fit was made with.
    column
        The optics: camera column of SLM points (u, v) at wavelengths, broadcasting
        (a rig's described relay, never the bench as built).

    Returns
    -------
    ndarray
        RMS column error over the field (px), one per band wavelength.

    Examples
    --------
    Not run here (it needs a lamp-anchored fit)::

        relay = desc.nominal_relay()
        error = anchored_form_error_px(
            anchoring.fit, anchoring.streaks, glass, slm_shape, tolerance,
            lambda u, v, lam: relay.forward(u, v, lam)[0],
        )
        error.shape
        # (31,)
    """
    maps = [_TracedMap(float(lam), column) for lam in fit.wavelengths_nm]
    traced = [_traced_streaks(data, fit, column) for data in lamps]
    noise_free = fit_anchored_wavelengths(
        maps, traced, glass, slm_shape, tolerance_nm, field_degree=field_degree, order=order
    )
    h, w = slm_shape
    u, v = (g.ravel() for g in np.meshgrid(np.linspace(0, w - 1, _FIELD_GRID[0]),
                                           np.linspace(0, h - 1, _FIELD_GRID[1])))  # fmt: skip
    band = np.linspace(*BAND_NM, BAND_SAMPLES)
    field = legendre2d_design(*field_coordinates(u, v, slm_shape), field_degree)
    fitted = (field @ noise_free.x_coeffs.T) @ _Spectral(glass, order).powers(band).T
    optics = np.asarray(column(u[:, None], v[:, None], band[None, :]))
    return np.sqrt(np.mean((fitted - optics) ** 2, axis=0))
