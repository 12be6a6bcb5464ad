"""Cross-column unmixing: open pixels in different SLM columns whose streaks overlap.

:func:`~sassi_bench.spectra.cells.unmix_rows` separates pixels stacked in one SLM column
exactly, because their bins fall on the same camera columns. A dense snapshot mask (a row
pitch set by the blur, as the SASSI paper's 5 px) also puts pixels of *neighbouring*
columns a few rows apart: their streaks overlap in rows, shifted along the streak by a
fraction of a bin, so no grouping by SLM column and bin separates them.

Grouping by *camera* column does: within one camera column every open pixel's light is
one blurred line across the rows, centred on its streak there, and nothing else
(:class:`StreakModel`). So the unknowns are each pixel's light in each camera column its
streak crosses, and the frame is fitted by least squares over every camera pixel the
streaks reach. The normal equations couple only pixels that meet in a camera column (a
banded system per column), are factorised once per mask (SuperLU) and solved again for
each background refinement in milliseconds. Each bin's light is then the sum over its own
columns (fractional end columns), exactly the quantity the row unmixing gives, so the
within-streak deblur applies unchanged.

On the sim rig (380 open pixels at a 6 px row pitch, a 512 x 800 window) a frame with 24
background refinements takes about 0.4 s and its spectra agree with the pinhole scan to
42.0 dB. The former solve (GMRES on the cell sums of a bin model painted uniformly over
each bin's columns, preconditioned per SLM column) took 120 s with 8 refinements for
35.4 dB: its model also tried to undo the camera columns that neighbouring bins share,
whose inverse amplifies noise (the deblur's job, with regularisation), and solved exactly
it diverged at a 5 px pitch.
"""

from __future__ import annotations

import math
from functools import cached_property

import numpy as np
from numba import njit
from numpy.typing import NDArray
from scipy.sparse import csc_array, csr_array, diags_array
from scipy.sparse.linalg import splu

from sassi_bench.spectra.geometry import StreakGeometry

__all__ = ["StreakModel", "columns_interact"]

#: Rows of a streak's profile in a camera column, above and below its centre, in blur sigmas.
PROFILE_SIGMAS = 6.0


@njit(nogil=True, error_model="numpy")
def _column_profiles(x_left, x_right, y, sigma, first, weight, centre, spread):  # pragma: no cover
    """Per pixel and camera column ``first[n] + k``: the summed fractions of the bins in
    it (``weight``) and their weighted mean centre row and blur sigma."""
    pixels, bins = y.shape
    for n in range(pixels):
        for b in range(bins):
            left, right = x_left[n, b], x_right[n, b]
            for c in range(math.floor(left + 0.5), math.floor(right + 0.5) + 1):
                overlap = min(c + 0.5, right) - max(c - 0.5, left)
                if overlap > 0.0:
                    k = c - first[n]
                    weight[n, k] += overlap
                    centre[n, k] += overlap * y[n, b]
                    spread[n, k] += overlap * sigma[b]
        for k in range(weight.shape[1]):
            if weight[n, k] > 0.0:
                centre[n, k] /= weight[n, k]
                spread[n, k] /= weight[n, k]


@njit(nogil=True, error_model="numpy")
def _design_entries(
    first, weight, centre, spread, reach, height, width, fill, pixel, unit, value
):  # pragma: no cover - compiled
    """Entries of the design matrix: camera pixel ``r * width + c`` holds ``value`` of
    unit ``n * K + k`` (pixel n's light in camera column ``c = first[n] + k``), the share
    of a Gaussian of the unit's sigma in row r. Written unit by unit, rows ascending: the
    order of a CSC matrix, so no sort is needed. Returns their number; when ``fill`` is
    False only a bound on it (no erf evaluated)."""
    pixels, columns = weight.shape
    count = 0
    for n in range(pixels):
        for k in range(columns):
            c = first[n] + k
            if not weight[n, k] > 0.0 or c < 0 or c >= width:
                continue
            s, y = spread[n, k], centre[n, k]
            scale = 1.0 / (s * math.sqrt(2.0))
            r0 = max(math.floor(y - reach * s - 0.5), 0)
            r1 = min(math.ceil(y + reach * s + 0.5), height - 1)
            if not fill:  # a bound: the tiny shares skipped below are counted too
                count += r1 - r0 + 1
                continue
            low = math.erf((r0 - 0.5 - y) * scale)
            for r in range(r0, r1 + 1):
                high = math.erf((r + 0.5 - y) * scale)  # each edge's erf once
                share = 0.5 * (high - low)
                low = high
                if share < 1e-9:
                    continue
                pixel[count] = r * width + c
                unit[count] = n * columns + k
                value[count] = share
                count += 1
    return count


@njit(nogil=True, error_model="numpy")
def _bin_entries(
    x_left, x_right, first, columns, width, fill, row, unit, value
):  # pragma: no cover
    """Entries of the bin sums: bin ``n * B' + b`` takes ``value`` (the column's fraction
    inside the bin) of unit ``n * columns + k``. Counts them only when ``fill`` is False."""
    pixels, bins = x_left.shape
    count = 0
    for n in range(pixels):
        for b in range(bins):
            left, right = x_left[n, b], x_right[n, b]
            for c in range(math.floor(left + 0.5), math.floor(right + 0.5) + 1):
                overlap = min(c + 0.5, right) - max(c - 0.5, left)
                if overlap > 0.0 and 0 <= c < width:
                    if fill:
                        row[count] = n * bins + b
                        unit[count] = n * columns + c - first[n]
                        value[count] = overlap
                    count += 1
    return count


class StreakModel:
    """The open pixels' light on the camera, per pixel and camera column, as a linear model.

    Unit ``(n, k)`` is pixel ``n``'s light in camera column ``first[n] + k``; it spreads
    over the rows as a Gaussian of the blur sigma at that column, centred on the streak
    (both the mean of the bins crossing the column, weighted by their fractions in it).
    :meth:`fit` finds the units by least squares over the camera pixels (normal equations
    factorised once, on first use), :meth:`render` paints them back, :meth:`bins` sums
    each bin's columns (the amplitudes :func:`~sassi_bench.spectra.cells.unmix_rows`
    gives, which the within-streak deblur takes).

    Parameters
    ----------
    geometry
        The open pixels' streak geometry, in the image's rows.
    shape
        The image (H, W).

    Examples
    --------
    >>> geo = StreakGeometry(np.array([0, 4]), np.array([3, 4]),
    ...                      np.array([[10.0, 11.0], [10.6, 11.6]]),
    ...                      np.array([[11.0, 12.0], [11.6, 12.6]]),
    ...                      np.array([[6.0, 6.0], [8.5, 8.5]]), np.array([1.0, 1.5]), guard=0)
    >>> model = StreakModel(geo, (16, 20))
    >>> light = np.arange(1.0, model.units + 1.0)
    >>> bool(np.allclose(model.fit(model.render(light)), light))
    True
    >>> model.bins(light).round(2).tolist()  # each bin: its columns' light by fraction
    [[1.5, 2.5], [4.1, 5.1]]
    """

    def __init__(self, geometry: StreakGeometry, shape: tuple[int, int]) -> None:
        height, width = (int(v) for v in shape)
        self.shape = (height, width)
        self.bin_shape = geometry.y.shape
        x_left = np.ascontiguousarray(geometry.x_left, dtype=np.float64)
        x_right = np.ascontiguousarray(geometry.x_right, dtype=np.float64)
        low = np.minimum(x_left, x_right).min(axis=1, initial=np.inf)
        high = np.maximum(x_left, x_right).max(axis=1, initial=-np.inf)
        first = np.floor(low + 0.5).astype(np.int64)
        columns = int((np.floor(high + 0.5) - first).max(initial=0)) + 1
        pixels = geometry.y.shape[0]
        weight, centre, spread = (np.zeros((pixels, columns)) for _ in range(3))
        _column_profiles(
            x_left, x_right, np.ascontiguousarray(geometry.y, dtype=np.float64),
            np.ascontiguousarray(geometry.sigma, dtype=np.float64), first, weight,
            centre, spread,
        )  # fmt: skip
        self.units = pixels * columns
        arguments = (first, weight, centre, spread, PROFILE_SIGMAS, height, width)
        none_i, none_f = np.empty(0, np.int64), np.empty(0)
        bound = _design_entries(*arguments, False, none_i, none_i, none_f)
        pixel, unit, value = np.empty(bound, np.int64), np.empty(bound, np.int64), np.empty(bound)
        count = _design_entries(*arguments, True, pixel, unit, value)
        starts = np.concatenate([[0], np.cumsum(np.bincount(unit[:count], minlength=self.units))])
        self.design = csc_array(
            (value[:count], pixel[:count], starts), shape=(height * width, self.units)
        )
        arguments = (x_left, x_right, first, columns, width)
        count = _bin_entries(*arguments, False, none_i, none_i, none_f)
        row, unit, value = np.empty(count, np.int64), np.empty(count, np.int64), np.empty(count)
        _bin_entries(*arguments, True, row, unit, value)
        # Entries come bin by bin, columns ascending: already the order of a CSR matrix.
        starts = np.concatenate([[0], np.cumsum(np.bincount(row, minlength=x_left.size))])
        self.to_bins = csr_array((value, unit, starts), shape=(x_left.size, self.units))

    @cached_property
    def _solver(self):
        """LU factors of the normal equations; units that reach no camera pixel are
        pinned to zero (a one on their diagonal)."""
        gram = (self.design.T @ self.design).tocsc()
        unseen = ~(gram.diagonal() > 0.0)
        return splu(csc_array(gram + diags_array(unseen.astype(np.float64)))), unseen

    def fit(self, image: NDArray[np.floating]) -> NDArray[np.float64]:
        """The units' light (U,) that best explains ``image`` (H, W), least squares."""
        lu, unseen = self._solver
        rhs = self.design.T @ np.asarray(image, dtype=np.float64).ravel()
        rhs[unseen] = 0.0
        return lu.solve(rhs)

    def render(self, light: NDArray[np.float64]) -> NDArray[np.float64]:
        """The camera image (H, W) of the units' light (U,)."""
        return (self.design @ light).reshape(self.shape)

    def bins(self, light: NDArray[np.float64]) -> NDArray[np.float64]:
        """Each (pixel, bin)'s light summed over the bin's columns, (N, B')."""
        return (self.to_bins @ light).reshape(self.bin_shape)


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
