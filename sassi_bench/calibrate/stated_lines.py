"""Laser lines known only to a test sheet's accuracy, measured against the other lines.

A rig without lamps states some laser lines by a test sheet's centre and accuracy (a
diode's line) and others exactly (a gas or solid-state line). The dispersion model's
column is a low-order polynomial in the glass index, so with more lines than the model
has terms the maps themselves say where each stated line sits: a sheet centre off the
true line leaves that line's streak off the polynomial the other lines draw. This module
weighs the two: each stated line's wavelength is the one that best fits the maps under
the joint model and the sheet together (a Gaussian prior at the sheet's centre with the
sheet's 1-sigma), as a wavelength solution weighs arc lines against a prior.

The maps' weight is each map's own correspondence scatter, or, where the model's form
misses the optics by more, that miss: on the described optics (the model fitted to the
columns they trace at the sheets) and, with degrees of freedom to spare, the lines'
scatter about the joint model at the estimate, as for the map's stated 1-sigma in
:mod:`sassi_bench.calibrate.dispersion`. Where the form misses, the estimate is pulled by
it: the same estimate made on the described optics without noise says how far, and that
offset is taken off the estimate and kept in its 1-sigma. Each line's 1-sigma is what the
fit carries into the map in place of the sheet's.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sassi_bench.calibrate.anchored_form import ColumnOptics
from sassi_bench.calibrate.dispersion import (
    LaserMap,
    _checked_wavelengths,
    _field_samples,
    _FieldSamples,
)
from sassi_bench.optics.glass import Glass, get_glass

__all__ = ["StatedLine", "estimate_stated_lines"]

#: Gauss-Newton steps of the joint estimate (the misses are close to linear in the
#: lines' offsets over a sheet's accuracy).
GAUSS_NEWTON_STEPS = 4

#: Finite-difference step of the misses' derivative in a line's wavelength (nm).
_STEP_NM = 0.01

#: The least a map's column is taken to be uncertain by (px): keeps the weights finite
#: for maps fitted to noise-free samples.
_MAP_FLOOR_PX = 1e-4


@dataclass(frozen=True)
class StatedLine:
    """One stated laser line: the sheet's centre and the maps' estimate of it.

    Attributes
    ----------
    label_nm
        The line's label (the rig's ``lasers_nm``: the sheet's centre).
    stated_sigma_nm
        The sheet's 1-sigma as the rig states it (``laser_tolerance_nm``).
    estimated_nm
        The wavelength the maps and the sheet together put the line at, less the
        model form's pull (``form_nm``).
    sigma_nm
        The estimate's 1-sigma: the maps' and the sheet's, and the model's form (how
        far the estimate moves a line on the described optics without noise), in
        quadrature.
    form_nm
        The form's pull: the estimate's offset on the described optics, taken off
        ``estimated_nm`` (0 when they were not given).
    correlation
        Other stated line's label -> the correlation of the two estimates' errors (the
        maps tie lines they place together; the form's part counted independent).
    """

    label_nm: float
    stated_sigma_nm: float
    estimated_nm: float
    sigma_nm: float
    form_nm: float = 0.0
    correlation: dict[float, float] = field(default_factory=dict)

    @property
    def moved_nm(self) -> float:
        """Estimate minus the sheet's centre (nm)."""
        return self.estimated_nm - self.label_nm


def estimate_stated_lines(
    maps: Sequence[LaserMap],
    glass: str | Glass,
    slm_shape: tuple[int, int],
    stated_sigma_nm: Mapping[float, float],
    column: ColumnOptics | None = None,
    field_degree: int = 5,
    order: int = 2,
    grid: tuple[int, int] = (33, 21),
) -> dict[float, StatedLine]:
    """Estimate the stated lines' wavelengths from the maps and their sheets together.

    Minimises, over the stated lines' wavelengths, the maps' columns' squared miss from
    the joint model fitted at those wavelengths (each map weighted by its noise, counted
    as the field's terms of independent numbers) plus each line's squared offset from
    its sheet centre in sheet sigmas. Lines not in ``stated_sigma_nm`` (or stated at 0)
    are exact. With ``column``, each map is weighed at no better than the model's miss of
    those optics, and the same estimate is made from the maps they trace at the sheet
    centres, without noise: how far it moves a line is the model form's pull, which is
    taken off the estimate and carried in its 1-sigma in quadrature.

    Parameters
    ----------
    maps, glass, slm_shape, field_degree, order, grid
        As for :func:`~sassi_bench.calibrate.dispersion.fit_dispersion`.
    stated_sigma_nm
        Label -> the sheet's 1-sigma (nm).
    column
        The optics as described (camera column of SLM points at wavelengths,
        broadcasting; a rig's described relay, never the bench as built).

    Returns
    -------
    dict
        Label -> :class:`StatedLine`, for every stated line with a 1-sigma above 0.

    Examples
    --------
    Not run here (it needs measured laser maps)::

        relay = desc.nominal_relay()
        lines = estimate_stated_lines(maps, "N-SF5", (300, 400), {441.93: 0.28},
                                      lambda u, v, lam: relay.forward(u, v, lam)[0])
        lines[441.93].estimated_nm
        # 441.54
    """
    g = glass if isinstance(glass, Glass) else get_glass(glass)
    labels = _checked_wavelengths(maps, order)
    sigma = np.array([float(stated_sigma_nm.get(float(x), 0.0)) for x in labels])
    free = np.flatnonzero(sigma > 0)
    if free.size == 0:
        return {}
    samples = _field_samples(maps, g, slm_shape, field_degree, grid)
    own = np.array([m.x.rms**2 * m.x.coeffs.size / max(m.x.n_inliers, 1) for m in maps])
    variance = np.maximum(own, _MAP_FLOOR_PX**2)
    traced = None
    if column is not None:
        traced = np.asarray(
            column(samples.u[None, :], samples.v[None, :], labels[:, None]), dtype=np.float64
        )
        # Where the model's form misses the optics, a map is known no better than that
        # miss: the maps' misses at the sheets are read against it, not against photons.
        variance = np.maximum(variance, _form_miss(samples, traced, labels, order) ** 2)
    offsets, covariance = _joint_offsets(samples, samples.xs, labels, sigma, variance, order)
    posterior = np.sqrt(np.diag(covariance))
    form = np.zeros_like(offsets)
    if traced is not None:
        form, _ = _joint_offsets(samples, traced, labels, sigma, variance, order)
    total = np.hypot(posterior, form)
    correlation = covariance / np.outer(total, total)
    return {
        float(labels[i]): StatedLine(
            label_nm=float(labels[i]),
            stated_sigma_nm=float(sigma[i]),
            estimated_nm=float(labels[i] + offsets[k] - form[k]),
            sigma_nm=float(total[k]),
            form_nm=float(form[k]),
            correlation={
                float(labels[j]): float(correlation[k, m]) for m, j in enumerate(free) if j != i
            },
        )
        for k, i in enumerate(free)
    }


def _column_miss(
    samples: _FieldSamples,
    xs: NDArray[np.float64],
    wavelengths_nm: NDArray[np.float64],
    variance: NDArray[np.float64],
    order: int,
) -> NDArray[np.float64]:
    """Columns ``xs`` (lines, points) less the joint model fitted to them at
    ``wavelengths_nm``, each line weighted by one over its standard deviation."""
    powers = samples.sx(wavelengths_nm)[:, None] ** np.arange(order + 1)[None, :]
    weight = 1.0 / np.sqrt(variance)
    # Weighted least squares over the lines; the field terms separate as in fit_x.
    coeffs = np.linalg.pinv(weight[:, None] * powers) @ (weight[:, None] * xs)
    predicted = powers @ (coeffs @ samples.field_pinv.T) @ samples.field_design.T
    return (xs - predicted) * weight[:, None]


def _form_miss(
    samples: _FieldSamples, traced: NDArray[np.float64], labels: NDArray[np.float64], order: int
) -> NDArray[np.float64]:
    """Each line's RMS miss over the field (px) of the model fitted to the columns the
    optics trace at ``labels``: how far the model's form is from those optics."""
    unweighted = np.ones(labels.size)
    return np.sqrt(np.mean(_column_miss(samples, traced, labels, unweighted, order) ** 2, axis=1))


def _joint_offsets(
    samples: _FieldSamples,
    xs: NDArray[np.float64],
    labels: NDArray[np.float64],
    sigma: NDArray[np.float64],
    own: NDArray[np.float64],
    order: int,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The stated lines' offsets from their sheets that best fit columns ``xs`` (lines,
    points) and the sheets together, and their covariance (nm squared)."""
    free = np.flatnonzero(sigma > 0)
    points, terms = samples.field_design.shape
    spare = labels.size - (order + 1) - free.size

    def miss(offsets: NDArray[np.float64], variance: NDArray[np.float64]) -> NDArray:
        lam = labels.copy()
        lam[free] += offsets
        return _column_miss(samples, xs, lam, variance, order) * np.sqrt(terms / points)

    def solve(variance: NDArray[np.float64]) -> tuple[NDArray, NDArray]:
        # Gauss-Newton on the stacked maps' misses and the sheets' rows: the misses are
        # close to linear in the offsets over a sheet's accuracy, and the last step's
        # normal equations are the estimate's inverse covariance.
        offsets = np.zeros(free.size)
        prior = np.diag(1.0 / sigma[free])
        for _ in range(GAUSS_NEWTON_STEPS):
            base = miss(offsets, variance).ravel()
            jacobian = np.stack(
                [
                    (miss(offsets + step, variance).ravel() - base) / _STEP_NM
                    for step in np.eye(free.size) * _STEP_NM
                ],
                axis=1,
            )
            normal = jacobian.T @ jacobian + prior.T @ prior
            gradient = jacobian.T @ base + prior.T @ (prior @ offsets)
            offsets = offsets - np.linalg.solve(normal, gradient)
        return offsets, np.linalg.inv(normal)

    offsets, covariance = solve(own)
    if spare > 0:
        # Where the lines scatter about the joint model by more than the maps' own
        # noise, the model's form misses the optics: weigh the maps by that scatter.
        scatter = float(np.sum(miss(offsets, np.ones_like(own)) ** 2)) / (terms * spare)
        if scatter > own.max():
            offsets, covariance = solve(np.maximum(own, scatter))
    return offsets, covariance
