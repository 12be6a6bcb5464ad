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
streaks reach. The normal equations split into one small system per camera column,
coupling only the pixels that meet there; sorted by first row each is a narrow skyline
matrix, built and Cholesky-factorised once per mask in compiled loops
(:mod:`sassi_bench.spectra._crosstalk_kernels`) and solved again for each background
refinement. Each bin's light is then the sum over its own columns (fractional end
columns), exactly the quantity the row unmixing gives, so the within-streak deblur
applies unchanged. A unit's profile is cut 4 sigmas from its centre (beyond, 6e-5 of its
light).

Compiled skyline solves replace a scipy sparse design with SuperLU factors, which gave the
same spectra at several times the CPU; ``benchmarks/bench_snapshot.py`` times them, and
``docs/notes/2026-11-29-docstring-measurements.md`` holds the measurements behind these choices.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sassi_bench._shared.arrays import check_shape
from sassi_bench.spectra import _crosstalk_kernels as _kernels
from sassi_bench.spectra.geometry import StreakGeometry
from sassi_bench.spectra.offset import BlockBackground

__all__ = ["StreakModel", "columns_interact"]

#: Rows of a streak's profile in a camera column, above and below its centre, in blur sigmas.
PROFILE_SIGMAS = 4.0

#: Stand-ins for the background's arrays when there is none (typed like them).
_NO_BACKGROUND = (
    np.zeros((1, 1)), np.zeros(1, np.int64), np.zeros((1, 1)), np.zeros(1, np.int64),
    np.zeros((1, 1)),
)  # fmt: skip


class StreakModel:
    """The open pixels' light on the camera, per pixel and camera column, as a linear model.

    Unit ``(n, k)`` is pixel ``n``'s light in camera column ``first[n] + k``; it spreads
    over the rows as a Gaussian of the blur sigma at that column, centred on the streak
    (both the mean of the bins crossing the column, weighted by their fractions in it).
    :meth:`fit` finds the units by least squares over the camera pixels, :meth:`render`
    paints them back, :meth:`bins` sums each bin's columns (the amplitudes
    :func:`~sassi_bench.spectra.cells.unmix_rows` gives, which the within-streak deblur
    takes), :meth:`residual_medians` gives the block medians of what the fitted light
    leaves, for the background's refinement.

    A unit lies in one camera column, so the normal equations are one small banded system
    per camera column; they are factorised when the model is built
    (:mod:`sassi_bench.spectra._crosstalk_kernels`), and the model holds each unit's
    profile over its rows, nothing of the frame's size.

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
        _kernels.column_profiles(
            x_left, x_right, np.ascontiguousarray(geometry.y, dtype=np.float64),
            np.ascontiguousarray(geometry.sigma, dtype=np.float64), first, weight,
            centre, spread,
        )  # fmt: skip
        self.units = pixels * columns
        self._x_left, self._x_right, self._first, self._columns = x_left, x_right, first, columns
        top = np.empty(self.units, np.int64)
        bottom = np.empty(self.units, np.int64)
        count = np.zeros(width, np.int64)
        placed = _kernels.unit_rows(
            first, weight, centre, spread, PROFILE_SIGMAS, height, width, top, bottom, count
        )
        col_start = np.zeros(width + 1, np.int64)
        np.cumsum(count, out=col_start[1:])
        slot_unit = np.empty(placed, np.int64)
        slot_top, slot_bottom = np.empty(placed, np.int64), np.empty(placed, np.int64)
        prof_start = np.empty(placed + 1, np.int64)
        total = _kernels.sort_units(
            first, columns, top, bottom, col_start, slot_unit, slot_top, slot_bottom, prof_start
        )
        prof = np.empty(total)
        _kernels.fill_profiles(
            slot_unit, slot_top, slot_bottom, centre.ravel(), spread.ravel(), prof_start,
            geometry.profile.cdf_table, prof,
        )  # fmt: skip
        envelope = np.empty(placed, np.int64)
        factor_start = np.empty(placed, np.int64)
        factor = _kernels.factor_columns(
            col_start, slot_top, slot_bottom, prof_start, prof, envelope, factor_start
        )
        # Everything per slot (camera column by column), so the loops read it in order.
        self._slot_unit = slot_unit
        self._layout = (col_start, slot_top, slot_bottom, prof_start, prof)
        self._factor = (envelope, factor_start, factor)

    def sums(self, image: NDArray[np.floating]) -> NDArray[np.float64]:
        """The right-hand sides of the normal equations for ``image`` (H, W): every slot's
        profile against the pixels (:meth:`solve` them; one image, many backgrounds)."""
        pixels = np.asarray(image)
        if pixels.dtype.kind not in "iuf" or not pixels.flags.c_contiguous:
            pixels = np.ascontiguousarray(pixels, dtype=np.float64)
        check_shape(
            pixels, self.shape, step="spectrum extraction", name="the frame",
            expected_for="the streak model", fix="pass the camera window the model was built for",
        )  # fmt: skip
        out = np.empty(self._slot_unit.size)
        _kernels.profile_sums(pixels, *self._layout, out)
        return out

    def solve(
        self, sums: NDArray[np.float64], background: BlockBackground | None = None
    ) -> NDArray[np.float64]:
        """The units' light (U,) from an image's :meth:`sums`, minus ``background`` (its
        share of each unit's sum evaluated on the units' rows only). Units whose light
        reaches no camera pixel are zero."""
        if background is None:
            arrays = (False, *_NO_BACKGROUND)
        else:
            arrays = (True, *background.kernel_arrays())
        slots = np.empty(self._slot_unit.size)
        _kernels.solve_columns(sums, *self._layout, *self._factor, *arrays, slots)
        light = np.zeros(self.units)
        light[self._slot_unit] = slots
        return light

    def fit(
        self, image: NDArray[np.floating], background: BlockBackground | None = None
    ) -> NDArray[np.float64]:
        """The units' light (U,) that best explains ``image`` (H, W) minus ``background``
        (evaluated at the units' pixels only), least squares. Units whose light reaches no
        camera pixel are zero."""
        return self.solve(self.sums(image), background)

    def render(self, light: NDArray[np.float64]) -> NDArray[np.float64]:
        """The camera image (H, W) of the units' light (U,)."""
        out = np.zeros(self.shape)
        slots = np.asarray(light, dtype=np.float64)[self._slot_unit]
        _kernels.render_columns(*self._layout, slots, out)
        return out

    def bins(self, light: NDArray[np.float64]) -> NDArray[np.float64]:
        """Each (pixel, bin)'s light summed over the bin's columns, (N, B')."""
        out = np.empty(self.bin_shape)
        _kernels.bin_sums(
            self._x_left, self._x_right, self._first, self._columns, self.shape[1],
            np.ascontiguousarray(light, dtype=np.float64), out,
        )  # fmt: skip
        return out

    def touched_blocks(self, block: tuple[int, int]) -> NDArray[np.bool_]:
        """The blocks (of ``block`` camera rows x columns) that some unit's rows reach."""
        by, bx = block
        touched = np.zeros((-(-self.shape[0] // by), -(-self.shape[1] // bx)), dtype=bool)
        col_start, top, bottom = self._layout[:3]
        _kernels.touched_blocks(col_start, top, bottom, by, bx, touched)
        return touched

    def residual_medians(
        self,
        image: NDArray[np.floating],
        light: NDArray[np.float64],
        block: tuple[int, int],
        wanted: NDArray[np.bool_],
        out: NDArray[np.float64],
    ) -> None:
        """Write into ``out`` the median of ``image`` minus the rendered ``light`` over
        every block (of ``block`` camera rows x columns) marked in ``wanted``.

        The residual of the whole blocks is gathered block by block (float32) and sorted
        in one call: numpy's vectorised sort of all the rows beats a compiled quickselect
        per block (``docs/notes/2026-12-01-measured-in-code-comments.md``)."""
        pixels = np.asarray(image)
        if pixels.dtype.kind not in "iuf" or not pixels.flags.c_contiguous:
            pixels = np.ascontiguousarray(pixels, dtype=np.float64)
        by, bx = (int(v) for v in block)
        wanted = np.ascontiguousarray(wanted, dtype=bool)
        whole = np.zeros(wanted.shape, dtype=bool)
        whole[: self.shape[0] // by, : self.shape[1] // bx] = True
        whole &= wanted
        index = np.flatnonzero(whole)
        row_of = np.full(wanted.shape, -1, np.int64)
        row_of.flat[index] = np.arange(index.size)
        full = np.empty((index.size, by * bx), np.float32)
        _kernels.residual_blocks(
            pixels, *self._layout, np.asarray(light, dtype=np.float64)[self._slot_unit],
            by, bx, wanted, row_of, full, out,
        )  # fmt: skip
        full.sort(axis=1)
        middle = by * bx // 2
        if by * bx % 2:
            out.flat[index] = full[:, middle]
        else:
            out.flat[index] = 0.5 * (full[:, middle - 1].astype(np.float64) + full[:, middle])


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
    reach = reach_sigmas * np.asarray(geometry.sigma)
    top = np.floor(geometry.y - reach).astype(np.int64)
    bottom = np.ceil(geometry.y + reach).astype(np.int64)
    left = np.floor(geometry.x_left).astype(np.int64)
    right = np.ceil(geometry.x_right).astype(np.int64)
    return bool(
        _kernels.meet(top, bottom, left, right, np.ascontiguousarray(geometry.cols, dtype=np.int64))
    )
