"""Cross-column unmixing: open pixels in different SLM columns whose streaks overlap.

:func:`~sassi_bench.spectra.cells.unmix_rows` separates pixels stacked in one SLM column
exactly, because their bins fall on the same camera columns. A dense snapshot mask (a row
pitch set by the blur, as the SASSI paper's 5 px) also puts pixels of *neighbouring*
columns a few rows apart: their streaks overlap in rows, shifted along the streak, so a
bin of one pixel collects parts of two bins of the other. That coupling is not banded
per column and bin, so it is solved for the whole frame at once:

* the forward model :func:`render_amplitudes` paints every (pixel, bin) amplitude back
  onto the camera (uniform over the bin's columns, the bundle's Gaussian blur across the
  rows), and its cell sums are the model of the measured cell sums;
* :func:`unmix_cells` solves ``cells(render(a)) = measured`` by GMRES, preconditioned by
  the per-column banded solve (which is exact when no columns interact, so the first
  iterate is the stacked solution and the Krylov steps only add the cross-column part).

The amplitudes are each bin's light summed over its own columns, as the row unmixing's,
so the within-streak deblur applies unchanged afterwards.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from numba import njit
from numpy.typing import NDArray
from scipy.sparse.linalg import LinearOperator, gmres

from sassi_bench.spectra.cells import (
    NEGLIGIBLE_COUPLING,
    CellLayout,
    cell_layout,
    cell_sums,
    column_cumsum,
    unmix_rows,
)
from sassi_bench.spectra.geometry import StreakGeometry

if TYPE_CHECKING:
    from sassi_bench.spectra.extract import SpectralDeblur
    from sassi_bench.spectra.offset import Background

__all__ = ["columns_interact", "extract_with_background", "render_amplitudes", "unmix_cells"]

#: Rows painted above and below a bin centre, in blur sigmas.
RENDER_SIGMAS = 6.0


@njit(nogil=True, error_model="numpy")
def _render(amplitudes, y, x_left, x_right, sigma, reach, image):  # pragma: no cover
    """Add every (pixel, bin) amplitude to ``image``: uniform over its columns (the
    fraction of each column inside the bin), Gaussian over the rows."""
    height, width = image.shape
    pixels, bins = amplitudes.shape
    for n in range(pixels):
        for b in range(bins):
            a = amplitudes[n, b]
            left, right = x_left[n, b], x_right[n, b]
            if a == 0.0 or not right > left:
                continue
            s = sigma[b]
            scale = 1.0 / (s * math.sqrt(2.0))
            centre = y[n, b]
            r0 = max(math.floor(centre - reach * s - 0.5), 0)
            r1 = min(math.ceil(centre + reach * s + 0.5), height - 1)
            c0 = max(math.floor(left + 0.5), 0)
            c1 = min(math.floor(right + 0.5), width - 1)
            per_column = a / (right - left)
            for r in range(r0, r1 + 1):
                share = 0.5 * (
                    math.erf((r + 0.5 - centre) * scale) - math.erf((r - 0.5 - centre) * scale)
                )
                if share < 1e-9:
                    continue
                value = per_column * share
                for c in range(c0, c1 + 1):
                    overlap = min(c + 0.5, right) - max(c - 0.5, left)
                    if overlap > 0.0:
                        image[r, c] += value * overlap


def render_amplitudes(
    amplitudes: NDArray[np.float64], geometry: StreakGeometry, shape: tuple[int, int]
) -> NDArray[np.float64]:
    """The camera image of (N, B') bin amplitudes (guard bins included), (H, W).

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0]), np.array([0]), np.array([[2.5]]),
    ...                      np.array([[5.5]]), np.array([[4.0]]), np.array([0.5]), guard=0)
    >>> image = render_amplitudes(np.array([[6.0]]), geo, (9, 9))
    >>> round(float(image.sum()), 6), image[4, 3:6].round(3).tolist()
    (6.0, [1.365, 1.365, 1.365])
    """
    image = np.zeros(shape)
    _render(
        np.ascontiguousarray(amplitudes, dtype=np.float64),
        np.ascontiguousarray(geometry.y, dtype=np.float64),
        np.ascontiguousarray(geometry.x_left, dtype=np.float64),
        np.ascontiguousarray(geometry.x_right, dtype=np.float64),
        np.ascontiguousarray(geometry.sigma, dtype=np.float64),
        RENDER_SIGMAS,
        image,
    )
    return image


def columns_interact(geometry: StreakGeometry, reach_sigmas: float = 3.0) -> bool:
    """Whether two open pixels of different SLM columns have bins that meet on the camera:
    the same camera columns and bin centres less than ``reach_sigmas`` blur sigmas (each
    side) apart in rows.

    Each pixel's streak is cut at its bins' centres into one box per bin; boxes are
    painted column-wise with the SLM column's id, so two different ids in one camera pixel
    within reach are a meeting. Cheap (one pass over the streak boxes).

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0, 5]), np.array([3, 4]),
    ...                      np.array([[10.0], [11.0]]), np.array([[14.0], [15.0]]),
    ...                      np.array([[4.0], [9.0]]), np.array([1.0]), guard=0)
    >>> columns_interact(geo), columns_interact(geo, reach_sigmas=2.0)
    (True, False)
    """
    n = geometry.rows.size
    if n < 2:
        return False
    reach = reach_sigmas * np.asarray(geometry.sigma)[None, :]
    top = np.floor(geometry.y - reach).astype(np.int64)
    bottom = np.ceil(geometry.y + reach).astype(np.int64)
    left = np.floor(geometry.x_left).astype(np.int64)
    right = np.ceil(geometry.x_right).astype(np.int64)
    return bool(
        _meet(top, bottom, left, right, np.ascontiguousarray(geometry.cols, dtype=np.int64))
    )


@njit(nogil=True)
def _meet(top, bottom, left, right, cols):  # pragma: no cover - compiled
    r0 = top.min()
    c0 = left.min()
    height = bottom.max() - r0 + 1
    width = right.max() - c0 + 1
    owner = np.full((height, width), -1, np.int64)
    for n in range(top.shape[0]):
        for b in range(top.shape[1]):
            for r in range(top[n, b] - r0, bottom[n, b] - r0 + 1):
                for c in range(left[n, b] - c0, right[n, b] - c0 + 1):
                    o = owner[r, c]
                    if o < 0:
                        owner[r, c] = cols[n]
                    elif o != cols[n]:
                        return True
    return False


def unmix_cells(
    sums: NDArray[np.float64],
    layout: CellLayout,
    geometry: StreakGeometry,
    floor: float = NEGLIGIBLE_COUPLING,
    *,
    rtol: float = 1e-6,
    max_iterations: int = 60,
    start: NDArray[np.float64] | None = None,
) -> NDArray[np.float64]:
    """Amplitudes (N, B') from cell sums when pixels of different columns overlap.

    Solves ``cell_sums(render(a)) = sums`` by GMRES with the per-column banded solve
    (:func:`~sassi_bench.spectra.cells.unmix_rows`) as the preconditioner, from ``start``
    (a previous solution of nearby sums) or else from the preconditioned sums.

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0, 4]), np.array([3, 4]),
    ...                      np.array([[10.0, 12.0], [11.0, 13.0]]),
    ...                      np.array([[12.0, 14.0], [13.0, 15.0]]),
    ...                      np.array([[6.0, 6.0], [8.0, 8.0]]), np.array([1.0, 1.0]), guard=0)
    >>> from sassi_bench.spectra.cells import cell_layout
    >>> layout = cell_layout(geo, (16, 20))
    >>> amplitudes = np.array([[3.0, 1.0], [2.0, 5.0]])
    >>> sums = cell_sums(column_cumsum(render_amplitudes(amplitudes, geo, (16, 20))), layout)
    >>> unmix_cells(sums, layout, geo).round(6).tolist()
    [[3.0, 1.0], [2.0, 5.0]]
    """
    shape = layout.shape
    size = sums.size
    cumulative = np.empty((shape[0] + 1, shape[1]))

    def forward(vector: NDArray[np.float64]) -> NDArray[np.float64]:
        image = render_amplitudes(vector.reshape(sums.shape), geometry, shape)
        return cell_sums(column_cumsum(image, cumulative), layout).ravel()

    def precondition(vector: NDArray[np.float64]) -> NDArray[np.float64]:
        return unmix_rows(vector.reshape(sums.shape), layout, geometry, floor).ravel()

    operator = LinearOperator((size, size), matvec=forward, dtype=np.float64)
    preconditioner = LinearOperator((size, size), matvec=precondition, dtype=np.float64)
    if start is None:
        start = precondition(sums.ravel())
    else:
        start = np.asarray(start, dtype=np.float64).ravel()
    solution, _ = gmres(
        operator, sums.ravel(), x0=start, M=preconditioner, rtol=rtol, atol=0.0,
        restart=max_iterations, maxiter=1,
    )  # fmt: skip
    return solution.reshape(sums.shape)


def extract_with_background(
    window: NDArray[np.floating],
    geometry: StreakGeometry,
    deblur: SpectralDeblur | None = None,
    *,
    block: tuple[int, int] = (8, 16),
    passes: int = 2,
    coupling_floor: float = NEGLIGIBLE_COUPLING,
) -> tuple[NDArray[np.float64], NDArray[np.bool_], Background]:
    """Spectra of a raw frame's open pixels with the background refined from the residual.

    A dense mask leaves few camera pixels outside the streak footprints (a 6 px row pitch
    on the sim rig: 10 %), too few for :func:`~sassi_bench.spectra.offset.estimate_background`
    to follow the closed pixels' leakage. So the first estimate (from those pixels) is
    refined ``passes`` times: the open pixels' light is unmixed (across columns when their
    streaks meet), painted back with :func:`render_amplitudes` and subtracted, and the
    background is re-estimated from the block medians of what is left over the *whole*
    frame.

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
    coupling_floor
        As :func:`~sassi_bench.spectra.extract.extract_spectra`.

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
    from sassi_bench.spectra.offset import estimate_background, streak_footprint

    image = np.asarray(window, dtype=np.float64)
    background = estimate_background(image, streak_footprint(geometry, image.shape), block)
    layout = cell_layout(geometry, image.shape)
    cross = columns_interact(geometry)
    raw = cell_sums(column_cumsum(image), layout)
    everywhere = np.zeros(image.shape, dtype=bool)
    amplitudes = None
    for refinement in range(int(passes) + 1):
        sums = raw - cell_sums(column_cumsum(background.image), layout)
        if cross:  # each pass starts from the last one's solution: few iterations
            amplitudes = unmix_cells(sums, layout, geometry, coupling_floor, start=amplitudes)
        else:
            amplitudes = unmix_rows(sums, layout, geometry, coupling_floor)
        if refinement == passes:
            break
        residual = image - render_amplitudes(amplitudes, geometry, image.shape)
        background = estimate_background(residual, everywhere, block)
    if deblur is not None:
        amplitudes = deblur.apply(amplitudes, geometry.rows, geometry.cols)
    return amplitudes[:, geometry.core], layout.off[:, geometry.core], background
