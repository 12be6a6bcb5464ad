"""Row unmixing with mixed blurs: a stacked pixel's light in a bin's columns is several
wavelengths, each blurred across the streak by its own width.

:func:`~sassi_bench.spectra.cells.unmix_rows` models the light of every pixel in bin
``b``'s columns as one Gaussian across the rows, of bin ``b``'s blur. Along the streak,
though, the columns of ``b`` also hold the light of the neighbouring bins ``k`` (the
forward model's spill ``C[b, k]``, :mod:`~sassi_bench.spectra.forward`), and those are
blurred across the streak by *their* widths: where the prism disperses least and the
blur is widest (about 12 nm and sigma 2.6-3.8 px a camera column at the red end on
``sim``) the blur changes by 10 % from one column to the next, and the light of a column
is a mixture of Gaussians 2-6 px wide. With pinholes stacked 5.4 camera rows apart, a
cell keeps only part of its pixel's light, so the mixture's tails decide how much of a
neighbour's light falls in it, and a single blur per bin misses it
(``docs/notes/2026-12-01-measured-in-code-comments.md``).

Here the profile of pixel ``n``'s light in bin ``b``'s columns is the mixture
``sum_k C[b, k] x[n, k] G(y[n, k], sigma_k)`` with ``x`` the pixel's first-pass column
sums (the separable unmixing's, a blurred stand-in for its spectrum), integrated over each
cell with a three-node Gauss quadrature in sigma (exact for the mixture's moments up to the
fifth) about the weighted mean centre: three nodes follow the mixture where two do not,
and exact Gaussians at every source would take four times as many Gaussian integrals (a
dozen sources against three nodes); the errors of each on a synthetic column
(``tests/spectra/test_row_mixture.py``) are in
``docs/notes/2026-12-01-measured-in-code-comments.md``. Only bins where the sources' blurs move
more than :data:`MIXING_FLOOR` of a pixel's light across a cell edge are solved again
(:meth:`RowMixture.mixed_bins`).

It raises the red end of a scan of stacked pinholes toward that of unstacked ones, for
about 1.6-1.7 times the assembly's CPU once compiled
(:mod:`~sassi_bench.spectra._mixture_kernels` says how); it is
:func:`~sassi_bench.reduce.scan.assemble_scan`'s default. Measured with
``benchmarks/red_end_bound.py`` (and ``--separable``): ``docs/notes/2026-11-27-red-end.md``
and ``docs/notes/2026-11-29-docstring-measurements.md``.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from sassi_bench.spectra import _mixture_kernels
from sassi_bench.spectra.cells import NEGLIGIBLE_COUPLING, CellLayout, coupling_reach, unmix_rows
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.geometry import StreakGeometry

__all__ = ["MIXING_FLOOR", "SPILL_FLOOR", "RowMixture", "unmix_rows_mixed"]

#: Sources that put less than this fraction of their light into a bin's columns are left
#: out of its mixture.
SPILL_FLOOR = 1e-3

#: Bins whose sources' blurs move less than this fraction of a pixel's light across a cell
#: edge (:meth:`RowMixture.mixed_bins`) keep the separable unmixing.
MIXING_FLOOR = 1e-2


@dataclass(frozen=True)
class RowMixture:
    """The sources of every bin's columns and their blurs, at the forward model's field
    points.

    Attributes
    ----------
    model
        The forward model (field points, spill ``C[p, b, k]`` and blur of every source).
    first, stop
        (B',) the range of sources ``k`` of each bin ``b`` (spill above
        :data:`SPILL_FLOOR` at some field point).
    sigma_high
        (B',) the widest blur of those sources, over the field points.
    moments
        (P, B', 2) the spill-weighted mean blur and mean squared blur of each bin's
        sources (a flat spectrum) at every field point.
    """

    model: StreakForwardModel
    first: NDArray[np.intp]
    stop: NDArray[np.intp]
    sigma_high: NDArray[np.float64]
    moments: NDArray[np.float64]

    @classmethod
    def from_model(cls, model: StreakForwardModel) -> RowMixture:
        """The sources of every bin from a forward model.

        Examples
        --------
        >>> model = StreakForwardModel(np.zeros(1), np.zeros(1), np.zeros((1, 3)),
        ...     np.array([[1.0, 2.0, 3.0]]), np.array([[[0.9, 0.1, 0], [0.1, 0.8, 0.1],
        ...     [0, 0.1, 0.9]]]), guard=0)
        >>> mix = RowMixture.from_model(model)
        >>> mix.first.tolist(), mix.stop.tolist(), mix.sigma_high.tolist()
        ([0, 0, 1], [2, 3, 3], [2.0, 3.0, 3.0])
        """
        spill = np.where(model.spill > SPILL_FLOOR, model.spill, 0.0)
        reaches = spill.max(axis=0) > 0.0  # (B', K)
        bins = reaches.shape[0]
        first = np.argmax(reaches, axis=1)
        stop = bins - np.argmax(reaches[:, ::-1], axis=1)
        high = np.where(reaches, model.row_sigma_px.max(axis=0)[None, :], 0.0).max(axis=1)
        weight = spill / spill.sum(axis=2, keepdims=True)
        sigma = model.row_sigma_px[:, None, :]
        moments = np.stack([(weight * sigma).sum(axis=2), (weight * sigma**2).sum(axis=2)], -1)
        return cls(model, first.astype(np.intp), stop.astype(np.intp), high, moments)

    def mixed_bins(self, geometry: StreakGeometry, floor: float = MIXING_FLOOR) -> NDArray[np.intp]:
        """Bins where the blurs of the sources reaching them move more than ``floor`` of
        a pixel's light across a cell edge at any distance from its centre, against the
        bin's own blur (the widest of ``geometry.sigma``), for a flat spectrum.

        The sources' spread about the bin's own blur is their spill-weighted RMS deviation
        (the largest over the field points); the share beyond an edge at ``h`` is
        ``Phi(-h / sigma)``. The choice depends on the bundle alone, not on the pixels a
        frame holds, so a region's cube is unmixed as the same region of the whole scan.

        Examples
        --------
        >>> moments = np.array([[[1.0, 1.0], [1.2, 1.2**2 + 0.04]]])  # (P, B', 2)
        >>> mix = RowMixture(None, *np.zeros((2, 2), np.intp), np.ones(2), moments)
        >>> geo = StreakGeometry(np.array([0, 5]), np.array([3, 3]), np.full((2, 2), 10.0),
        ...                      np.full((2, 2), 11.0), np.array([[4.0, 4.0], [9.0, 9.0]]),
        ...                      np.array([1.0, 1.2]), guard=0)
        >>> mix.mixed_bins(geo).tolist()  # one blur; spread
        [1]
        """
        own = geometry.sigma.max(axis=0, initial=0.0)
        mean, square = self.moments[..., 0], self.moments[..., 1]
        spread = np.sqrt(np.maximum(square - 2.0 * own * mean + own**2, 0.0).max(axis=0))
        h = np.linspace(0.0, 6.0, 97)[None, :] * (own + spread)[:, None]
        cdf = geometry.profile.cdf
        change = np.abs(cdf(-h / (own + spread)[:, None]) - cdf(-h / own[:, None]))
        return np.flatnonzero(change.max(axis=1) > floor).astype(np.intp)


def unmix_rows_mixed(
    sums: NDArray[np.float64],
    layout: CellLayout,
    geometry: StreakGeometry,
    mixture: RowMixture,
    first: NDArray[np.float64] | None = None,
    floor: float = NEGLIGIBLE_COUPLING,
    mixing: float = MIXING_FLOOR,
    bins: NDArray[np.intp] | None = None,
) -> NDArray[np.float64]:
    """Amplitudes (N, B') of stacked pixels from their cell sums, each pixel's light in a
    bin's columns blurred as the mixture of its sources (module docstring).

    ``first`` is the separable unmixing of the same sums (computed when not given), the
    estimate the mixtures are weighed with; bins that the mixture changes less than
    ``mixing`` (:meth:`RowMixture.mixed_bins`), or not in ``bins``, keep it. ``floor`` is
    the coupling left out, as for :func:`~sassi_bench.spectra.cells.unmix_rows`.

    Examples
    --------
    Not run here (it needs measured frames)::

        mixture = RowMixture.from_model(model)
        amplitudes = unmix_rows_mixed(raw, layout, geo, mixture)
    """
    sums = np.ascontiguousarray(sums, dtype=np.float64)
    if first is None:
        first = unmix_rows(sums, layout, geometry, floor)
    out = np.array(first, dtype=np.float64, order="C")
    mixed = mixture.mixed_bins(geometry, mixing)
    if bins is not None:
        mixed = np.intersect1d(mixed, bins).astype(np.intp)
    if mixed.size == 0 or geometry.y.shape[0] == 0:
        return out
    model = mixture.model
    points = model.point(geometry.rows, geometry.cols)
    nodes = np.empty((geometry.y.shape[0], mixed.size, 7))
    widest = np.empty(mixed.size)  # the widest node any pixel has in each bin
    _mixture_kernels.mixture_nodes(
        points,
        np.ascontiguousarray(model.spill, dtype=np.float64),
        np.ascontiguousarray(model.row_sigma_px, dtype=np.float64),
        np.ascontiguousarray(geometry.y, dtype=np.float64),
        mixture.first,
        mixture.stop,
        mixed,
        np.ascontiguousarray(first, dtype=np.float64),
        nodes,
        widest,
    )
    # The reach of each bin's couplings from its widest node.
    sigma = np.array(geometry.sigma)
    sigma[:, mixed] = np.maximum(sigma[:, mixed], widest)
    wide = replace(geometry, sigma=sigma)
    reach = coupling_reach(layout, wide, floor)[mixed]
    _mixture_kernels.unmix_mixed(
        sums,
        layout.lo,
        layout.hi,
        layout.index,
        mixed,
        reach,
        nodes,
        geometry.profile.cdf_table,
        out,
    )
    return out
