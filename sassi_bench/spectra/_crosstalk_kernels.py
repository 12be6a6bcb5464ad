"""Compiled loops of the cross-column unmixing (numba, compiled on first use; no on-disk
cache, see :mod:`sassi_bench.spectra._kernels`).

The streak model's unknowns are *units*: an open pixel's light in one camera column. A
unit's light lies in its own camera column only, so the least-squares normal equations
split into one small system per camera column, coupling the units of that column whose
row profiles overlap. Sorted by first row, each is a narrow variable-band (skyline)
matrix: its Cholesky factor has no entries outside the envelope of the matrix itself.
So a frame's model is

* the *layout* (:func:`unit_rows`, :func:`sort_units`): per camera column, its units
  sorted by first row, each with its rows and its profile (the share of a Gaussian of the
  unit's blur in every row, from the blur profile's tabulated CDF,
  :mod:`sassi_bench.maths.normal`);
* the skyline Cholesky factor of every column's system (:func:`factor_columns`, by
  :func:`~sassi_bench.maths.banded.skyline_cholesky`);

and every background refinement is a right-hand side per unit (the profile against the
frame minus the background, evaluated from the background's spline on the unit's rows
only), two triangular solves per column (:func:`solve_columns`), and the block medians of
the residual on the blocks the streaks reach (:func:`residual_block_medians`). Each
touches the camera pixels of the streak windows a fixed number of times: the cost follows
the open pixels' streaks, not the frame.

A sparse design matrix, its normal equations and their SuperLU factors would cost many
times more, for factorising alone (``docs/notes/2026-12-01-measured-in-code-comments.md``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sassi_bench.maths.banded import skyline_cholesky, skyline_solve
from sassi_bench.maths.normal import CDF_RANGE, CDF_STEPS_PER_UNIT
from sassi_bench.maths.order_statistics import median

_JIT = {"cache": False, "nogil": True, "error_model": "numpy"}
#: Loops whose sums may be reassociated (vectorised): results change in the last bits only.
_SUMS = dict(_JIT, fastmath={"reassoc", "contract"})

#: Profile shares below this are dropped (the model's design never held them).
TINY_SHARE = 1e-9

#: An unsigned index: numba skips the negative-index wraparound on it.
_U = np.uint64


@njit(**_JIT)
def column_profiles(x_left, x_right, y, sigma, first, weight, centre, spread):  # pragma: no cover
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
                    spread[n, k] += overlap * sigma[n, b]
        for k in range(weight.shape[1]):
            if weight[n, k] > 0.0:
                centre[n, k] /= weight[n, k]
                spread[n, k] /= weight[n, k]


@njit(**_JIT)
def unit_rows(
    first, weight, centre, spread, reach, height, width, top, bottom, count
):  # pragma: no cover
    """Rows ``top .. bottom`` (inclusive, clipped to the image) of every unit ``n * K + k``
    within ``reach`` sigmas of its centre, and the number of units per camera column
    (``count``). Units outside the image, or with no light in their column, get
    ``bottom < top``. Returns the number of units placed."""
    pixels, columns = weight.shape
    placed = 0
    for n in range(pixels):
        for k in range(columns):
            u = n * columns + k
            top[u] = 0
            bottom[u] = -1
            c = first[n] + k
            if not weight[n, k] > 0.0 or c < 0 or c >= width:
                continue
            s, y = spread[n, k], centre[n, k]
            r0 = max(math.floor(y - reach * s - 0.5), 0)
            r1 = min(math.ceil(y + reach * s + 0.5), height - 1)
            if r0 > r1:
                continue
            top[u] = r0
            bottom[u] = r1
            count[c] += 1
            placed += 1
    return placed


@njit(**_JIT)
def sort_units(
    first, columns, top, bottom, col_start, slot_unit, slot_top, slot_bottom, prof_start
):  # pragma: no cover
    """Fill the slots: the units of camera column ``c`` at ``col_start[c] ..
    col_start[c + 1] - 1``, sorted by first row (``slot_unit``: the unit of each slot);
    ``slot_top``, ``slot_bottom`` its rows, ``prof_start[i]`` the offset of its profile.
    Returns the profiles' total length."""
    width = col_start.size - 1
    cursor = col_start[:-1].copy()
    pixels = first.size
    for n in range(pixels):
        for k in range(columns):
            u = n * columns + k
            if bottom[u] < top[u]:
                continue
            c = first[n] + k
            i = cursor[c]
            cursor[c] += 1
            # Insertion by first row: pixels come in raster order, so nearly sorted.
            while i > col_start[c] and top[slot_unit[i - 1]] > top[u]:
                slot_unit[i] = slot_unit[i - 1]
                i -= 1
            slot_unit[i] = u
    total = 0
    for c in range(width):
        for i in range(col_start[c], col_start[c + 1]):
            prof_start[i] = total
            u = slot_unit[i]
            slot_top[i] = top[u]
            slot_bottom[i] = bottom[u]
            total += bottom[u] - top[u] + 1
    prof_start[col_start[width]] = total
    return total


@njit(**_JIT)
def fill_profiles(
    slot_unit, top, bottom, centre, spread, prof_start, table, prof
):  # pragma: no cover
    """Every slot's profile: the share of the blur's profile (its unit's centre and sigma)
    in each of its rows ``top[i] .. bottom[i]`` (shares under :data:`TINY_SHARE` are zero).

    The CDF is read from its tabulated cubics (``table``, as
    :func:`~sassi_bench.maths.normal.tabulated_cdf` reads it), stepping the table position
    by a fixed increment a row (the same values, without its per-call checks)."""
    last = table.shape[0]
    for i in range(slot_unit.size):
        u = slot_unit[i]
        y = centre[u]
        scale = CDF_STEPS_PER_UNIT / spread[u]
        start = (top[i] - 0.5 - y) / spread[u]
        t = (start + CDF_RANGE) * CDF_STEPS_PER_UNIT
        low = 0.0
        out = prof[prof_start[i] : prof_start[i + 1]]
        for q in range(out.size + 1):
            if t <= 0.0:
                high = 0.0
            elif t >= last:
                high = 1.0
            else:
                k = int(t)
                v = t - k
                high = table[k, 0] + v * (table[k, 1] + v * (table[k, 2] + v * table[k, 3]))
            if q > 0:
                share = high - low
                out[q - 1] = share if share >= TINY_SHARE else 0.0
            low = high
            t += scale


@njit(**_SUMS)
def factor_columns(
    col_start, top, bottom, prof_start, prof, envelope, factor_start
):  # pragma: no cover
    """The skyline Cholesky factor of every camera column's normal equations.

    Slot ``i`` couples with the slots ``envelope[i] .. i`` of its column (the first one
    whose rows reach its first row, and every one after it); its factor row is stored at
    ``factor_start[i] ..`` (``i - envelope[i] + 1`` values, the *reciprocal* of the
    diagonal last). A unit whose profile is all zero (light that reaches no camera pixel)
    is pinned: a one on its diagonal and nothing else. Returns the factor's values.

    Inner loops index with unsigned offsets (:func:`_U`): numba checks a signed index for
    a negative value at every access, which stops the loops from being vectorised."""
    width = col_start.size - 1
    total = 0
    for c in range(width):
        lo, hi = col_start[c], col_start[c + 1]
        longest = 0
        for i in range(lo, hi):
            longest = max(longest, bottom[i] - top[i])
        for i in range(lo, hi):
            first_row = top[i]
            e = i
            j = i - 1
            # Slots before i start no later; they can reach row first_row only if they
            # start within the longest profile of it.
            while j >= lo and top[j] + longest >= first_row:
                if bottom[j] >= first_row:
                    e = j
                j -= 1
            envelope[i] = e
            factor_start[i] = total
            total += i - e + 1
    factor = np.zeros(total)
    for c in range(width):
        lo, hi = col_start[c], col_start[c + 1]
        for i in range(lo, hi):
            ti, bi = top[i], bottom[i]
            ei = envelope[i]
            fi = factor_start[i]
            for j in range(ei, i + 1):
                # Gram entry: the profiles' overlap.
                r0 = max(ti, top[j])
                r1 = min(bi, bottom[j])
                g = 0.0
                if r1 >= r0:
                    pa = _U(prof_start[i] + r0 - ti)
                    pb = _U(prof_start[j] + r0 - top[j])
                    for q in range(_U(r1 - r0 + 1)):
                        g += prof[pa + q] * prof[pb + q]
                factor[fi + j - ei] = g
        skyline_cholesky(envelope, factor_start, factor, lo, hi)
    return factor


#: Camera columns read together: more columns' column-major writes collide in the cache
#: (``docs/notes/2026-12-01-measured-in-code-comments.md``).
STRIP = 16


@njit(**_SUMS)
def profile_sums(image, col_start, top, bottom, prof_start, prof, sums):  # pragma: no cover
    """Every slot's profile against ``image``: the right-hand sides of the normal
    equations, into ``sums``.

    The frame is read :data:`STRIP` columns at a time, row by row, into a column-major
    buffer: read column by column, every pixel would be a cache miss."""
    height = image.shape[0]
    width = col_start.size - 1
    strip = np.empty((STRIP, height))
    for c0 in range(0, width, STRIP):
        c1 = min(width, c0 + STRIP)
        if col_start[c0] == col_start[c1]:
            continue
        r0, r1 = height, -1
        for i in range(col_start[c0], col_start[c1]):
            r0 = min(r0, top[i])
            r1 = max(r1, bottom[i])
        for r in range(r0, r1 + 1):
            for c in range(c0, c1):
                strip[c - c0, r] = image[r, c]
        for c in range(c0, c1):
            column = strip[c - c0]
            for i in range(col_start[c], col_start[c + 1]):
                pa = _U(prof_start[i])
                pb = _U(top[i])
                acc = 0.0
                for q in range(_U(bottom[i] - top[i] + 1)):
                    acc += prof[pa + q] * column[pb + q]
                sums[i] = acc


@njit(**_SUMS)
def solve_columns(
    sums, col_start, top, bottom, prof_start, prof, envelope, factor_start, factor,
    has_background, coefficients, row_index, row_basis, col_index, col_basis, light,
):  # fmt: skip  # pragma: no cover
    """The slots' light (into ``light``) from their right-hand sides ``sums``
    (:func:`profile_sums`) minus the background's (when ``has_background``: the tensor
    spline ``coefficients`` with the rows' and columns' bases, evaluated from the column's
    first to its last slot's row), by the two triangular solves with the skyline factor of
    every camera column (:func:`~sassi_bench.maths.banded.skyline_solve`)."""
    height = row_index.size
    width = col_start.size - 1
    line = np.empty(coefficients.shape[0])
    column = np.empty(height)
    degree = row_basis.shape[1]
    for c in range(width):
        lo, hi = col_start[c], col_start[c + 1]
        if lo == hi:
            continue
        for i in range(lo, hi):
            light[i] = sums[i]
        if has_background:
            first_row, last_row = height, -1
            for i in range(lo, hi):
                first_row = min(first_row, top[i])
                last_row = max(last_row, bottom[i])
            # The spline's coefficients summed along this column: one value per row basis.
            j0 = col_index[c]
            for k in range(row_index[first_row], row_index[last_row] + degree):
                v = 0.0
                for q in range(col_basis.shape[1]):
                    v += coefficients[k, j0 + q] * col_basis[c, q]
                line[k] = v
            for r in range(first_row, last_row + 1):
                k = _U(row_index[r])
                v = 0.0
                for p in range(degree):
                    v += row_basis[r, p] * line[k + _U(p)]
                column[r] = v
            for i in range(lo, hi):
                pa = _U(prof_start[i])
                pb = _U(top[i])
                acc = 0.0
                for q in range(_U(bottom[i] - top[i] + 1)):
                    acc += prof[pa + q] * column[pb + q]
                light[i] -= acc
        skyline_solve(envelope, factor_start, factor, light, lo, hi)


@njit(**_SUMS)
def render_columns(col_start, top, bottom, prof_start, prof, light, out):  # pragma: no cover
    """Add every slot's light, painted along its profile, to ``out`` (H, W)."""
    width = col_start.size - 1
    for c in range(width):
        for i in range(col_start[c], col_start[c + 1]):
            x = light[i]
            a = prof[prof_start[i] : prof_start[i + 1]]
            for q in range(a.size):
                out[top[i] + q, c] += x * a[q]


@njit(**_SUMS)
def residual_blocks(
    image, col_start, top, bottom, prof_start, prof, light, by, bx, wanted, row_of, full, medians
):  # pragma: no cover
    """The residual (``image`` minus the slots' rendered ``light``) of every block
    ``(i, j)`` (``by`` x ``bx`` camera pixels) marked in ``wanted``: a whole block's
    pixels are written to ``full[row_of[i, j]]`` (their median is taken by a vectorised
    sort of all blocks at once, outside), an edge block's median (fewer pixels) straight
    to ``medians[i, j]``. Block columns are done one at a time in a column-major strip, so
    no frame-sized residual is formed and a profile is subtracted as one contiguous run."""
    height = image.shape[0]
    width = col_start.size - 1
    ny, nx = wanted.shape
    strip = np.empty((bx, by * ny))
    buffer = np.empty(by * bx)
    for j in range(nx):
        c0 = j * bx
        c1 = min(width, c0 + bx)
        i0 = ny
        i1 = -1
        for i in range(ny):
            if wanted[i, j]:
                i0 = min(i0, i)
                i1 = i
        if i1 < 0:
            continue
        r0 = i0 * by
        r1 = min(height, (i1 + 1) * by)
        for r in range(r0, r1):
            for c in range(c0, c1):
                strip[c - c0, r] = image[r, c]
        for c in range(c0, c1):
            column = strip[c - c0]
            for s in range(col_start[c], col_start[c + 1]):
                x = light[s]
                pa = _U(prof_start[s])
                pb = _U(top[s])
                for q in range(_U(bottom[s] - top[s] + 1)):
                    column[pb + q] -= x * prof[pa + q]
        for i in range(i0, i1 + 1):
            if not wanted[i, j]:
                continue
            b0 = i * by
            b1 = min(height, b0 + by)
            row = row_of[i, j]
            if row >= 0 and b1 - b0 == by and c1 - c0 == bx:
                out = full[row]
                for c in range(bx):
                    for r in range(by):
                        out[c * by + r] = strip[c, b0 + r]
            else:
                n = 0
                for c in range(c1 - c0):
                    for r in range(b0, b1):
                        buffer[n] = strip[c, r]
                        n += 1
                medians[i, j] = median(buffer, n)


@njit(**_JIT)
def touched_blocks(col_start, top, bottom, by, bx, touched):  # pragma: no cover
    """Mark the blocks that any slot's rows reach."""
    width = col_start.size - 1
    for c in range(width):
        j = c // bx
        for s in range(col_start[c], col_start[c + 1]):
            for i in range(top[s] // by, bottom[s] // by + 1):
                touched[i, j] = True


@njit(**_JIT)
def bin_sums(x_left, x_right, first, columns, width, light, out):  # pragma: no cover
    """Each (pixel, bin)'s light: its units' light in the bin's columns, each by the
    column's fraction inside the bin."""
    pixels, bins = x_left.shape
    for n in range(pixels):
        for b in range(bins):
            left, right = x_left[n, b], x_right[n, b]
            total = 0.0
            for c in range(math.floor(left + 0.5), math.floor(right + 0.5) + 1):
                overlap = min(c + 0.5, right) - max(c - 0.5, left)
                if overlap > 0.0 and 0 <= c < width:
                    total += overlap * light[n * columns + c - first[n]]
            out[n, b] = total


@njit(**_JIT)
def meet(top, bottom, left, right, cols):  # pragma: no cover
    """Whether boxes of different ``cols`` overlap (see ``columns_interact``)."""
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
