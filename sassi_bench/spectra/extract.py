"""Spectrum extraction: the spectrum of every open SLM pixel of a frame, at the bundle's bins.

A frame of open pixels is a sum of streaks: pixel ``j``'s light of bin ``b`` is spread
uniformly over the bin's camera columns (``x_left .. x_right`` from the bundle) and
blurred by the bundle's Gaussian ``sigma_b`` in both directions. Extraction inverts that
model in two separable, vectorised steps:

1. **Rows** (:mod:`sassi_bench.spectra.cells`). Each (pixel, bin) is summed over the
   bin's columns and its cell of rows, and the overlap of pixels stacked in one SLM
   column is undone with a banded solve; pixels of different SLM columns whose streaks
   overlap are unmixed jointly (:mod:`sassi_bench.spectra.crosstalk`).
2. **Columns.** Within a streak the blur also spills each bin into its neighbours; the
   regularised inverse of that spill is the deblur (:mod:`sassi_bench.spectra.deblur`).

:func:`extract_spectra` works on a background-free frame;
:func:`extract_with_background` refines the background of a raw frame from the fit's
residual (:mod:`sassi_bench.spectra.offset`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_ndim, check_shape
from sassi_bench.spectra.cells import (
    NEGLIGIBLE_COUPLING,
    cell_layout,
    cell_sums,
    column_cumsum,
    unmix_rows,
)
from sassi_bench.spectra.crosstalk import StreakModel, columns_interact
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.offset import Background, estimate_background, streak_footprint

__all__ = ["extract_spectra", "extract_with_background"]


def extract_spectra(
    image: ArrayLike,
    geometry: StreakGeometry,
    deblur: SpectralDeblur | None = None,
    coupling_floor: float = NEGLIGIBLE_COUPLING,
    cross_columns: bool | None = False,
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Spectra (N, B) of the open pixels of a background-free frame.

    Parameters
    ----------
    image
        Frame with the background offset (and dark level) removed, (H, W).
    geometry
        From :func:`~sassi_bench.spectra.geometry.streak_geometry` for the frame's open
        pixels.
    deblur
        The within-streak unmixing
        (:meth:`~sassi_bench.spectra.deblur.SpectralDeblur.from_bundle`); None keeps each
        bin's raw column sum (spectrally blurred, but no noise amplification).
    coupling_floor
        Stacked neighbours that can couple less than this into a cell are neglected
        (:func:`~sassi_bench.spectra.cells.coupling_reach`; 0 keeps all).
    cross_columns
        Also unmix pixels of different SLM columns whose streaks overlap (dense snapshot
        masks; :class:`~sassi_bench.spectra.crosstalk.StreakModel`); None does so only when
        some do (:func:`~sassi_bench.spectra.crosstalk.columns_interact`).

    Returns
    -------
    spectra : ndarray
        Signal per pixel and bin (camera units), (N, B).
    off_frame : ndarray
        True where part of a bin's window fell off the camera, (N, B).
    """
    image = np.asarray(image, dtype=np.float64)
    check_ndim(image, 2, step="spectrum extraction", name="the frame", fix="pass one 2-D frame")
    if geometry.rows.size == 0:
        nb = geometry.sigma.size - 2 * geometry.guard
        return np.zeros((0, nb)), np.zeros((0, nb), dtype=bool)
    layout = cell_layout(geometry, image.shape)
    if cross_columns is None:
        cross_columns = columns_interact(geometry)
    if cross_columns:
        model = StreakModel(geometry, image.shape)
        amplitudes = model.bins(model.fit(image))
    else:
        sums = cell_sums(column_cumsum(image), layout)
        amplitudes = unmix_rows(sums, layout, geometry, coupling_floor)
    if deblur is not None:
        amplitudes = deblur.apply(amplitudes, geometry.rows, geometry.cols)
    core = geometry.core
    return amplitudes[:, core], layout.off[:, core]


def extract_with_background(
    window: NDArray[np.floating],
    geometry: StreakGeometry,
    deblur: SpectralDeblur | None = None,
    *,
    block: tuple[int, int] = (8, 16),
    passes: int = 2,
    start: NDArray[np.floating] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], Background]:
    """Spectra of a raw frame's open pixels with the background refined from the residual.

    A dense mask leaves few camera pixels outside the streak footprints (a 6 px row pitch
    on the sim rig: 10 %), too few for :func:`~sassi_bench.spectra.offset.estimate_background`
    to follow the closed pixels' leakage. So the first estimate (from those pixels) is
    refined ``passes`` times: the open pixels' light is fitted
    (:class:`~sassi_bench.spectra.crosstalk.StreakModel`, across columns), painted back and
    subtracted, and the background is re-estimated from the block medians of what is left
    over the *whole* frame. The model is factorised once, so a pass costs one block-median
    estimate and two sparse products.

    Parameters
    ----------
    window
        The raw frame (camera rows any streak can reach), dark level included.
    geometry
        :func:`~sassi_bench.spectra.geometry.streak_geometry` of the open pixels, in the
        window's rows.
    deblur
        The within-streak unmixing (None keeps each bin's column sum).
    block
        Camera (rows, columns) of the background's median blocks.
    passes
        Background refinements (0: the footprint-based estimate only).
    start
        A background image of the window's shape to refine instead of the footprint-based
        first estimate (video: the previous frame's, which a slowly moving scene leaves
        nearly right, so a few passes follow it).

    Returns
    -------
    spectra : ndarray
        (N, B) at the bundle's bins, camera units.
    off_frame : ndarray
        (N, B) True where part of a bin's window fell off the camera.
    background : Background
        The last background estimate.

    Examples
    --------
    >>> spectra, off, bg = extract_with_background(window, geometry, deblur)  # doctest: +SKIP
    """
    image = np.asarray(window, dtype=np.float64)
    if start is not None:
        check_shape(
            start,
            image.shape,
            step="spectrum extraction",
            name="the starting background",
            expected_for="the window",
            fix="pass the background of a frame of the same camera window",
        )
        background = Background(np.asarray(start, dtype=np.float64), float("nan"), 1.0)
    else:
        background = estimate_background(image, streak_footprint(geometry, image.shape), block)
    model = StreakModel(geometry, image.shape)
    everywhere = np.zeros(image.shape, dtype=bool)
    for refinement in range(int(passes) + 1):
        light = model.fit(image - background.image)
        if refinement == passes:
            break
        background = estimate_background(image - model.render(light), everywhere, block)
    amplitudes = model.bins(light)
    if deblur is not None:
        amplitudes = deblur.apply(amplitudes, geometry.rows, geometry.cols)
    off = cell_layout(geometry, image.shape).off
    return amplitudes[:, geometry.core], off[:, geometry.core], background
