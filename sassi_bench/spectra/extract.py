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

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from sassi_bench._shared.arrays import check_ndim, check_shape
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.cells import (
    NEGLIGIBLE_COUPLING,
    cell_layout,
    cell_sums,
    column_cumsum,
    unmix_rows,
)
from sassi_bench.spectra.crosstalk import StreakModel
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.offset import (
    BlockBackground,
    block_values,
    first_block_estimate,
)

__all__ = ["DenseModel", "dense_model", "extract_spectra", "extract_with_background"]


def extract_spectra(
    image: ArrayLike,
    geometry: StreakGeometry,
    deblur: SpectralDeblur | None = None,
    coupling_floor: float = NEGLIGIBLE_COUPLING,
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
        nb = np.shape(geometry.y)[1] - 2 * geometry.guard
        return np.zeros((0, nb)), np.zeros((0, nb), dtype=bool)
    layout = cell_layout(geometry, image.shape)
    sums = cell_sums(column_cumsum(image), layout)
    amplitudes = unmix_rows(sums, layout, geometry, coupling_floor)
    if deblur is not None:
        amplitudes = deblur.apply(amplitudes, geometry.rows, geometry.cols)
    core = geometry.core
    return amplitudes[:, core], layout.off[:, core]


#: Blocks around the streaks' blocks whose medians (of pure background) are taken too, once
#: a frame: they hold the spline surface under the streaks' edges as the whole frame did.
RING_BLOCKS = 2
#: A background carried from the previous frame is no guide when the pure-background blocks
#: around the streaks moved by more than this share of the level (the median over them):
#: a light switched: above what a moving scene moves them, below what a light stepped up
#: by a few per cent does (``docs/notes/2026-12-01-measured-in-code-comments.md``).
JUMP = 0.01


@dataclass(frozen=True)
class DenseModel:
    """What :func:`extract_with_background` builds from the open pixels alone, before any
    frame: the streak model (factorised) and the blocks its streaks reach (``touched``)
    and those with a ring of :data:`RING_BLOCKS` around them (``around``). A video builds
    the next frame's as soon as its mask is planned (:func:`dense_model`).

    Examples
    --------
    Not run here (it needs measured frames)::

        prepared = dense_model(geometry, window.shape)
        spectra, off, bg = extract_with_background(
            window, geometry, prepared=prepared)
    """

    model: StreakModel
    block: tuple[int, int]
    touched: NDArray[np.bool_]
    around: NDArray[np.bool_]


def dense_model(
    geometry: StreakGeometry, shape: tuple[int, int], block: tuple[int, int] = (8, 16)
) -> DenseModel:
    """The :class:`DenseModel` of the open pixels of ``geometry`` on a camera window of
    ``shape`` (H, W), with background blocks of ``block`` camera rows x columns."""
    shape = (int(shape[0]), int(shape[1]))
    block = (int(block[0]), int(block[1]))
    model = StreakModel(geometry, shape)
    touched = model.touched_blocks(block)
    around = ndimage.binary_dilation(
        touched, structure=np.ones((3, 3), bool), iterations=RING_BLOCKS
    )
    return DenseModel(model, block, touched, around)


def extract_with_background(
    window: NDArray[np.floating] | NDArray[np.integer],
    geometry: StreakGeometry,
    deblur: SpectralDeblur | None = None,
    *,
    block: tuple[int, int] = (8, 16),
    passes: int = 2,
    start: BlockBackground | NDArray[np.floating] | None = None,
    settle: int = 0,
    prepared: DenseModel | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], BlockBackground]:
    """Spectra of a raw frame's open pixels with the background refined from the residual.

    A dense mask leaves few camera pixels outside the streak footprints (a 6 px row pitch
    on the sim rig: 10 %), too few for :func:`~sassi_bench.spectra.offset.estimate_background`
    to follow the closed pixels' leakage. So the first estimate (from those pixels) is
    refined ``passes`` times: the open pixels' light is fitted
    (:class:`~sassi_bench.spectra.crosstalk.StreakModel`, across columns) and the
    background re-estimated as the block medians of the frame minus that light, on every
    block the streaks reach (and, once, a ring of :data:`RING_BLOCKS` blocks around them),
    through the same cubic spline surface (:class:`~sassi_bench.spectra.offset.BlockBackground`).
    Blocks no streak reaches keep their values (the first estimate's, or the previous
    frame's), so the cost follows the open pixels' streak windows, not the frame: the
    model is factorised once, the frame's sums against the profiles taken once, and a
    pass costs the block medians and a solve per camera column.

    Parameters
    ----------
    window
        The raw frame (camera rows any streak can reach), dark level included (any
        integer or float type; it is not copied).
    geometry
        :func:`~sassi_bench.spectra.geometry.streak_geometry` of the open pixels, in the
        window's rows.
    deblur
        The within-streak unmixing (None keeps each bin's column sum).
    block
        Camera (rows, columns) of the background's median blocks.
    passes
        Background refinements (0: the first estimate only).
    start
        The background to refine instead of the footprint-based first estimate: a
        :class:`~sassi_bench.spectra.offset.BlockBackground` of the window (video: the
        previous frame's, which a slowly moving scene leaves nearly right, so a few passes
        follow it), or a background image of the window's shape (taken by its block
        medians).
    settle
        With ``start``: refine up to this many passes in all (instead of ``passes``) when
        the first pass finds the pure-background blocks around the streaks moved by more
        than :data:`JUMP` of the level since ``start`` (a sudden change of the leakage).
    prepared
        The :func:`dense_model` of ``geometry`` on this window and ``block``, built
        before (else built here).

    Returns
    -------
    spectra : ndarray
        (N, B) at the bundle's bins, camera units.
    off_frame : ndarray
        (N, B) True where part of a bin's window fell off the camera.
    background : BlockBackground
        The last background estimate (its ``image`` on demand).

    Examples
    --------
    Not run here (it needs measured frames)::

        spectra, off, bg = extract_with_background(window, geometry, deblur)
    """
    image = np.asarray(window)
    check_ndim(image, 2, step="spectrum extraction", name="the frame", fix="pass one 2-D frame")
    if image.dtype.kind not in "iuf" or not image.flags.c_contiguous:
        image = np.ascontiguousarray(image, dtype=np.float64)
    shape = (int(image.shape[0]), int(image.shape[1]))
    block = (int(block[0]), int(block[1]))
    if prepared is None:
        prepared = dense_model(geometry, shape, block)
    elif prepared.model.shape != shape or prepared.block != block:
        raise ProcedureError(
            step_error(
                "spectrum extraction",
                f"the prepared streak model is of a {prepared.model.shape} window in "
                f"{prepared.block} blocks, the frame's window is {shape} in {block} blocks",
                "prepare the model for this camera window and blocks",
            )
        )
    model, touched, around = prepared.model, prepared.touched, prepared.around
    if start is None:
        measured = first_block_estimate(image, geometry, block, around)
    elif isinstance(start, BlockBackground):
        if start.shape != shape or start.block != block:
            raise ProcedureError(
                step_error(
                    "spectrum extraction",
                    f"the starting background is of a {start.shape} window in {start.block} "
                    f"blocks, the frame's window is {shape} in {block} blocks",
                    "pass the background of a frame of the same camera window and blocks",
                )
            )
        measured = start.values.copy()
    else:
        check_shape(
            start,
            shape,
            step="spectrum extraction",
            name="the starting background",
            expected_for="the window",
            fix="pass the background of a frame of the same camera window",
        )
        measured = block_values(np.asarray(start, dtype=np.float64), block)
    background = BlockBackground.from_values(measured, shape, block)
    sums = model.sums(image)
    total, refinement = int(passes), 0
    while True:
        light = model.solve(sums, background)
        if refinement >= total:
            break
        # The ring holds pure background: its medians once a frame.
        model.residual_medians(
            image, light, block, around if refinement == 0 else touched, measured
        )
        if refinement == 0 and start is not None and settle > total:
            ring = around & ~touched
            level = np.median(np.abs(measured[touched])) if touched.any() else 0.0
            moved = np.abs(measured[ring] - background.values[ring])
            if ring.any() and level > 0 and np.median(moved) > JUMP * level:
                total = int(settle)
        background = BlockBackground.from_values(measured, shape, block)
        refinement += 1
    amplitudes = model.bins(light)
    if deblur is not None:
        amplitudes = deblur.apply(amplitudes, geometry.rows, geometry.cols)
    off = cell_layout(geometry, shape).off
    return amplitudes[:, geometry.core], off[:, geometry.core], background
