"""Compiled loops of the scan assembly (numba): streak geometry, the reading pass over a
frame, cell sums and the row unmixing.

Why compiled: per (pixel, bin) cell, the work is a handful of flops (a window of two or
three columns, a few Gaussian integrals, one row of a banded elimination), so as numpy
the cost is whole-array passes and temporaries over (pixels x bins x neighbours) arrays,
and Python calls per row of the banded systems; per camera pixel, the reading pass needs
a cumulative sum, a footprint test, two accumulators and a saturation count, which numpy
does in as many passes over the frame. Fused loops do each once and release the GIL, so
the scan's frame threads run in parallel, for a fraction of numpy's CPU
(``docs/notes/2026-12-01-measured-in-code-comments.md``).

Compiled on first use in a process (a few seconds). numba's on-disk cache is not used:
it pickles into the package folder, and nothing this project persists is pickled. Every
function works on plain arrays; the interface is :mod:`sassi_bench.spectra.geometry`,
:mod:`sassi_bench.spectra.cells`, :mod:`sassi_bench.spectra.offset` and the scan assembly.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from sassi_bench.maths.banded import band_solve
from sassi_bench.maths.normal import tabulated_cdf

#: A cell reaches at least this far (camera rows) from its centre, so it always holds the
#: row of its centre (a row belongs to a cell by its upper edge, up to one row away).
MIN_CELL_REACH_PX = 1.0


@njit(nogil=True, error_model="numpy")
def _polynomial(coeffs, n, s):  # pragma: no cover - compiled
    """``sum_k coeffs[n, k] * s**k`` by Horner's rule."""
    value = coeffs[n, coeffs.shape[1] - 1]
    for k in range(coeffs.shape[1] - 2, -1, -1):
        value = value * s + coeffs[n, k]
    return value


@njit(nogil=True, error_model="numpy")
def streak_bins(
    cx, cy, s_edges, s_centres, guard, x_left, x_right, y
):  # pragma: no cover - compiled
    """Column bounds and centre rows of every bin of every pixel, guard bins included.

    ``cx``, ``cy`` (N, K) are each pixel's polynomials in the spectral coordinates
    ``s_edges`` (the bin edges', for x) and ``s_centres`` (the bin centres', for y). The
    ``guard`` one-pixel bins at each end continue the band's first and last bins
    outwards on their rows.
    """
    bins = s_centres.size
    stop = guard + bins
    for n in range(cx.shape[0]):
        previous = _polynomial(cx, n, s_edges[0])
        for b in range(bins):
            edge = _polynomial(cx, n, s_edges[b + 1])
            x_left[n, guard + b] = min(previous, edge)
            x_right[n, guard + b] = max(previous, edge)
            previous = edge
            y[n, guard + b] = _polynomial(cy, n, s_centres[b])
        for k in range(guard):
            x_left[n, k] = x_left[n, guard] - (guard - k)
            x_right[n, k] = x_left[n, k] + 1.0
            y[n, k] = y[n, guard]
            x_left[n, stop + k] = x_right[n, stop - 1] + k
            x_right[n, stop + k] = x_left[n, stop + k] + 1.0
            y[n, stop + k] = y[n, stop - 1]


@njit(nogil=True, error_model="numpy")
def column_cumsum(image, out):  # pragma: no cover - compiled
    """``out[r + 1, c] = out[r, c] + image[r, c]``, ``out[0] = 0``, row by row."""
    height, width = image.shape
    for c in range(width):
        out[0, c] = 0.0
    for r in range(height):
        for c in range(width):
            out[r + 1, c] = out[r, c] + image[r, c]


@njit(nogil=True, error_model="numpy")
def paint_rectangles(top, bottom, left, right, mask):  # pragma: no cover - compiled
    """Set ``mask[top:bottom, left:right]`` for every rectangle (bounds within the mask)."""
    for k in range(top.size):
        for r in range(top[k], bottom[k]):
            for c in range(left[k], right[k]):
                mask[r, c] = True


@njit(nogil=True, error_model="numpy")
def read_window(
    image, top, bottom, left, right, saturation, cumulative, total, count, marks
):  # pragma: no cover - compiled
    """One pass over a frame: what the scan's reading pass needs of every pixel.

    - ``cumulative``: the column cumulative sum (as :func:`column_cumsum`), non-finite
      pixels counted as 0;
    - the finite pixels outside every rectangle ``[top, bottom) x [left, right)`` (the
      streak footprints, bounds within the image) added to ``total`` and counted in
      ``count``;
    - returns how many pixels are ``>= saturation`` or not finite.

    The rectangles are not painted: each adds +1 and -1 at its column bounds of its rows
    in ``marks`` ((H, W + 1) integers, zero on entry and left zero), and a running sum
    along each row tells whether a pixel is covered. Painting the prototype's stacked,
    overlapping footprints wrote 10 million pixels a frame; this writes 0.2 million.
    """
    height, width = image.shape
    for k in range(top.size):
        for r in range(top[k], bottom[k]):
            marks[r, left[k]] += 1
            marks[r, right[k]] -= 1
    free = np.empty(width, dtype=np.bool_)
    bad = 0
    for c in range(width):
        cumulative[0, c] = 0.0
    for r in range(height):
        depth = 0
        for c in range(width):
            depth += marks[r, c]
            free[c] = depth == 0
        marks[r, :] = 0
        # Without branches, so that the compiler vectorises the pass over the pixels.
        for c in range(width):
            value = float(image[r, c])
            finite = abs(value) < math.inf  # False for NaN too
            value = value if finite else 0.0
            bad += (not finite) or value >= saturation
            cumulative[r + 1, c] = cumulative[r, c] + value
            use = free[c] and finite
            total[r, c] += value if use else 0.0
            count[r, c] += use
    return bad


@njit(nogil=True, error_model="numpy")
def cell_bounds(
    y, sigma, index, reach_sigmas, height, width, x_left, x_right, lo, hi, off
):  # pragma: no cover - compiled
    """Each cell's continuous row bounds (pixel edges) ``lo``, ``hi`` and its ``off`` flag.

    The cell of (pixel, bin) is the rows nearer to its bin centre than to the stacked
    neighbours' (``index``: (G, S) pixels of an SLM column, top to bottom, -1 pads at the
    end), at most ``reach_sigmas`` blur sigmas away but at least one row; a row belongs to
    a cell when its upper edge lies in the cell. The one-row floor keeps the centre's row
    in the cell of a spot much narrower than a row (a field blur fitted from the lasers
    and extrapolated past them thinned the singlet arm's blue end to 0.04 px, whose
    cells then held no row and unmixed to 0 / 0). Returns how many (pixel, bin) have a
    non-finite centre or column bound (their cells are left unset: the caller refuses such
    a geometry).
    """
    groups, stack = index.shape
    bins = y.shape[1]
    bad = 0
    for g in range(groups):
        for s in range(stack):
            n = index[g, s]
            if n < 0:
                break
            up = index[g, s - 1] if s > 0 else -1
            down = index[g, s + 1] if s + 1 < stack else -1
            for b in range(bins):
                centre = y[n, b]
                if not (
                    math.isfinite(centre)
                    and math.isfinite(x_left[n, b])
                    and math.isfinite(x_right[n, b])
                ):
                    bad += 1
                    continue
                reach = max(reach_sigmas * sigma[n, b], MIN_CELL_REACH_PX)
                upper = centre - reach
                if up >= 0:
                    upper = max(upper, 0.5 * (centre + y[up, b]))
                lower = centre + reach
                if down >= 0:
                    lower = min(lower, 0.5 * (centre + y[down, b]))
                first = math.ceil(upper - 0.5)
                last = math.ceil(lower - 0.5) - 1
                lo[n, b] = first - 0.5
                hi[n, b] = last + 0.5
                off[n, b] = (
                    first < 0
                    or last >= height
                    or x_left[n, b] < -0.5
                    or x_right[n, b] > width - 0.5
                )
    return bad


@njit(nogil=True, error_model="numpy", inline="always")
def _cell_sum(cumulative, lo, hi, left, right):  # pragma: no cover - compiled
    """Sum of one cell (rows ``[lo, hi]``, columns ``[left, right]``) of an image from its
    column cumulative sum (see :func:`cell_sums`)."""
    height = cumulative.shape[0] - 1
    width = cumulative.shape[1]
    top = min(max(math.floor(lo + 0.5), 0), height)
    bottom = min(max(math.floor(hi + 0.5), 0), height)
    first, last = math.floor(left + 0.5), math.floor(right + 0.5)
    total = 0.0
    if first >= 0 and last < width:
        if first == last:
            total = (right - left) * (cumulative[bottom, first] - cumulative[top, first])
        elif first < last:
            total = (first + 0.5 - left) * (cumulative[bottom, first] - cumulative[top, first])
            for c in range(first + 1, last):
                total += cumulative[bottom, c] - cumulative[top, c]
            total += (right - last + 0.5) * (cumulative[bottom, last] - cumulative[top, last])
    else:  # partly off the frame: the edge columns stand in for those beyond
        for c in range(first, last + 1):
            weight = min(c + 0.5, right) - max(c - 0.5, left)
            if weight > 0.0:
                column = min(max(c, 0), width - 1)
                total += min(weight, 1.0) * (cumulative[bottom, column] - cumulative[top, column])
    return total


@njit(nogil=True, error_model="numpy")
def cell_sums(cumulative, x_left, x_right, lo, hi, out):  # pragma: no cover - compiled
    """Sum of each cell of an image from its column cumulative sum ``(H + 1, W)``.

    Columns count with the fraction of ``[c - 0.5, c + 0.5]`` inside the bin: the first
    and last column of a bin with their fractions, those between whole. Rows and columns
    beyond the frame are clipped to it (such cells are flagged ``off``).
    """
    pixels, bins = lo.shape
    for n in range(pixels):
        for b in range(bins):
            out[n, b] = _cell_sum(cumulative, lo[n, b], hi[n, b], x_left[n, b], x_right[n, b])


@njit(nogil=True, error_model="numpy")
def coupling_reach(y, lo, hi, sigma, index, floor, table, out):  # pragma: no cover - compiled
    """Per bin, how many stacked neighbours away a coupling can exceed ``floor``.

    Pixel ``s + d`` (``d > 0``) lies at least ``d`` times the closest spacing below
    pixel ``s``, and the lower edge of cell ``s`` (which has a neighbour below) at most
    the largest such extent below its centre, so pixel ``s + d`` puts at most
    ``Phi((extent_below - d * spacing) / sigma)`` of its light into cell ``s`` (``sigma``:
    the bin's widest blur); likewise upwards.
    """
    groups, stack = index.shape
    bins = y.shape[1]
    spacing = np.full(bins, np.inf)
    below = np.full(bins, -np.inf)  # largest (lower edge - centre) of cells with a neighbour below
    above = np.full(bins, -np.inf)  # largest (centre - upper edge) of cells with one above
    count = 0
    for g in range(groups):
        for s in range(stack):
            n = index[g, s]
            if n < 0:
                break
            count = max(count, s + 1)
            if s == 0:
                continue
            m = index[g, s - 1]
            for b in range(bins):
                spacing[b] = min(spacing[b], abs(y[n, b] - y[m, b]))
                below[b] = max(below[b], hi[m, b] - y[m, b])
                above[b] = max(above[b], y[n, b] - lo[n, b])
    for b in range(bins):
        extent = max(below[b], above[b])
        distance = 0
        while (
            distance + 1 < count
            and tabulated_cdf((extent - (distance + 1) * spacing[b]) / sigma[b], table) > floor
        ):
            distance += 1
        out[b] = distance


@njit(nogil=True, error_model="numpy")
def _reach_runs(reach):  # pragma: no cover - compiled
    """Per distance ``k`` (0 .. max reach), the runs of consecutive bins whose reach is at
    least ``k``: ``starts[k, :counts[k]]``, ``stops[k, :counts[k]]``."""
    bins = reach.size
    widest = 0
    for b in range(bins):
        widest = max(widest, reach[b])
    starts = np.zeros((widest + 1, bins), dtype=np.intp)
    stops = np.zeros((widest + 1, bins), dtype=np.intp)
    counts = np.zeros(widest + 1, dtype=np.intp)
    for k in range(widest + 1):
        for b in range(bins):
            if reach[b] < k:
                continue
            if counts[k] == 0 or stops[k, counts[k] - 1] != b:
                starts[k, counts[k]] = b
                counts[k] += 1
            stops[k, counts[k] - 1] = b + 1
    return starts, stops, counts


@njit(nogil=True, error_model="numpy")
def solve_undominated(
    band, x, size, reach, cells, columns, dominant, rest, alone, alone_x, out
):  # pragma: no cover - compiled
    """Mark which of a column's banded systems are diagonally dominant, and solve the
    others alone with partial pivoting (:func:`~sassi_bench.maths.banded.band_solve`).

    ``band[s, d + w, j]`` = ``A_j[s, s + d]`` and ``x[:, j]`` the right-hand side of system
    ``j`` (``size`` rows, bandwidth ``reach[j]``); ``dominant[j]`` is set for each; the
    solution of a system that is not is written to ``out[cells[s], columns[j]]``. The
    dominant ones are left to the caller's elimination without pivoting, all at once.
    """
    w = (band.shape[1] - 1) // 2
    count = dominant.size
    dominant[:] = True
    for s in range(size):
        rest[:] = 0.0
        for d in range(2 * w + 1):
            if d != w:
                for j in range(count):
                    rest[j] += abs(band[s, d, j])
        for j in range(count):
            dominant[j] = dominant[j] and abs(band[s, w, j]) > rest[j]
    for j in range(count):
        if not dominant[j]:
            p = reach[j]
            alone[:size, : 3 * p + 1] = 0.0
            for s in range(size):
                for d in range(-p, p + 1):
                    alone[s, d + p] = band[s, d + w, j]
                alone_x[s] = x[s, j]
            band_solve(alone, alone_x, size, p)
            for s in range(size):
                out[cells[s], columns[j]] = alone_x[s]


@njit(nogil=True, error_model="numpy")
def unmix_rows(sums, y, lo, hi, sigma, index, reach, table, out):  # pragma: no cover - compiled
    """Amplitudes of stacked pixels from their cell sums: per SLM column and bin, the
    banded system ``A[s, s + d]`` = light of pixel ``s + d`` in cell ``s`` (its profile,
    of its own blur ``sigma[s + d, bin]``, integrated over the cell: the CDF ``table``),
    ``|d| <= reach[bin]``, solved exactly.

    The systems of all bins of an SLM column are built and solved together, bins
    innermost, each coupling distance ``d`` only over the runs of bins that reach that far
    (:func:`_reach_runs`). Adjacent cells share an edge, so each Gaussian integral at an
    edge is evaluated once for both. Diagonally dominant systems (the usual case: a pixel
    keeps more of its light in its cell than its neighbours put there) are eliminated
    without pivoting, which is stable for them, all bins at once: solving one system at a
    time is bound by the latency of each row's division and update, which interleaving
    hides (``docs/notes/2026-12-01-measured-in-code-comments.md``). Any other system is
    solved alone with partial pivoting.
    """
    groups, stack = index.shape
    bins = sums.shape[1]
    starts, stops, counts = _reach_runs(reach)
    w = counts.size - 1  # the widest reach
    scale = 1.0 / sigma
    band = np.zeros((stack, 2 * w + 1, bins))  # band[s, d + w, b] = A_b[s, s + d]
    x = np.empty((stack, bins))
    previous = np.empty((2 * w + 1, bins))  # CDFs at the previous cell's lower edge
    current = np.empty((2 * w + 1, bins))
    rest = np.empty(bins)
    dominant = np.empty(bins, dtype=np.bool_)
    factor = np.empty(bins)
    alone = np.empty((stack, 3 * w + 1))
    alone_x = np.empty(stack)
    columns = np.arange(bins)
    for g in range(groups):
        size = 0
        while size < stack and index[g, size] >= 0:
            size += 1
        # Entries are written only where a bin reaches; near the end of the stack, entries
        # beyond it may still hold those of a longer stack.
        band[max(0, size - w) : size] = 0.0
        for s in range(size):
            n = index[g, s]
            up = index[g, s - 1] if s > 0 else -1
            for d in range(-min(w, s), min(w, size - 1 - s) + 1):
                m = index[g, s + d]
                k = abs(d)
                for run in range(counts[k]):
                    for b in range(starts[k, run], stops[k, run]):
                        centre = y[m, b]
                        lower = tabulated_cdf((hi[n, b] - centre) * scale[m, b], table)
                        # Pixel m at this cell's upper edge: the previous cell's lower edge.
                        if up >= 0 and d < reach[b] and lo[n, b] == hi[up, b]:
                            upper = previous[d + 1 + w, b]
                        else:
                            upper = tabulated_cdf((lo[n, b] - centre) * scale[m, b], table)
                        current[d + w, b] = lower
                        band[s, d + w, b] = lower - upper
            previous, current = current, previous
            for b in range(bins):
                x[s, b] = sums[n, b]
        cells = index[g]
        solve_undominated(band, x, size, reach, cells, columns, dominant, rest, alone, alone_x, out)
        # Elimination without pivoting of all bins' systems at once (the results of
        # systems that are not dominant are discarded). Row r = k + dr takes a multiple of
        # row k only in bins that reach dr; entry j = k + dj changes only in bins that
        # reach both dr and dj.
        for k in range(size):
            last = min(w, size - 1 - k)
            for dr in range(1, last + 1):
                r = k + dr
                for run in range(counts[dr]):
                    for b in range(starts[dr, run], stops[dr, run]):
                        factor[b] = band[r, w - dr, b] / band[k, w, b]
                        x[r, b] -= factor[b] * x[k, b]
                for dj in range(1, last + 1):
                    level = max(dr, dj)
                    for run in range(counts[level]):
                        for b in range(starts[level, run], stops[level, run]):
                            band[r, dj - dr + w, b] -= factor[b] * band[k, dj + w, b]
        for i in range(size - 1, -1, -1):
            for dj in range(1, min(w, size - 1 - i) + 1):
                for run in range(counts[dj]):
                    for b in range(starts[dj, run], stops[dj, run]):
                        x[i, b] -= band[i, dj + w, b] * x[i + dj, b]
            for b in range(bins):
                x[i, b] /= band[i, w, b]
        for s in range(size):
            n = cells[s]
            for b in range(bins):
                if dominant[b]:
                    out[n, b] = x[s, b]


@njit(nogil=True, error_model="numpy")
def column_weights(x_left, x_right, width, total, square):  # pragma: no cover - compiled
    """Per cell, ``sum w`` and ``sum w^2`` of the fractions ``w`` of its columns
    ``[c - 0.5, c + 0.5]`` inside the bin ``[x_left, x_right]`` clipped to the camera's
    ``width`` (the noise model's column weights, :func:`sassi_bench.spectra.noise.column_weights`).

    Column by column from the bin's first, as the numpy form adds them (columns past the
    bin add zeros there, which changes no sum).
    """
    pixels, bins = x_left.shape
    for n in range(pixels):
        for b in range(bins):
            total[n, b], square[n, b] = _weights(x_left[n, b], x_right[n, b], width)


@njit(nogil=True, error_model="numpy", inline="always")
def _weights(x_left, x_right, width):  # pragma: no cover - compiled
    """``sum w`` and ``sum w^2`` of one cell's columns, as :func:`column_weights` adds them:
    the first column, the whole columns after it (both bounds outside them: ``w`` is 1
    exactly), then the rest to the last."""
    left = min(max(x_left, -0.5), width - 0.5)
    right = min(max(x_right, -0.5), width - 0.5)
    centre = math.floor(left + 0.5)
    w = min(centre + 0.5, right) - max(centre - 0.5, left)
    t = w if w > 0.0 else 0.0
    q = w * w if w > 0.0 else 0.0
    centre += 1.0
    while centre + 0.5 <= right and centre - 0.5 >= left:
        t += 1.0
        q += 1.0
        centre += 1.0
    while centre - 0.5 < right:
        w = min(centre + 0.5, right) - max(centre - 0.5, left)
        if w > 0.0:
            t += w
            q += w * w
        centre += 1.0
    return t, q


@njit(nogil=True, error_model="numpy", inline="always")
def _variance(raw, t, q, lo, hi, height, dark, gain, read2, row_gain):  # pragma: no cover
    """The noise model's variance of one cell sum ``raw`` with column weights ``t``, ``q``
    (:meth:`sassi_bench.spectra.noise.CountsNoise.variance`, its numpy form's operations
    in its order)."""
    top = int(min(max(lo + 0.5, 0.0), height))
    bottom = int(min(max(hi + 0.5, 0.0), height))
    rows = float(bottom - top)
    above = raw - dark * rows * t
    above = 0.0 if above < 0.0 else above
    share = q / t if t > 0.0 else 0.0
    photons = share * above / gain
    return (photons + rows * q * read2) * row_gain


@njit(nogil=True, error_model="numpy")
def cell_variance(
    raw_sums, x_left, x_right, lo, hi, height, width, dark, gain, read2, row_gain, out
):  # pragma: no cover - compiled
    """The noise model's variance of every cell sum (:meth:`sassi_bench.spectra.noise.
    CountsNoise.variance`) in one pass: each cell's column weights (as
    :func:`column_weights`), its rows (as ``CellLayout.bottom - CellLayout.top``) and its
    photon and read noise, with the numpy form's operations in its order, so the values
    are the same to the bit, without the numpy form's six (N, B') temporaries.
    """
    pixels, bins = x_left.shape
    for n in range(pixels):
        for b in range(bins):
            t, q = _weights(x_left[n, b], x_right[n, b], width)
            out[n, b] = _variance(
                float(raw_sums[n, b]), t, q, lo[n, b], hi[n, b], height, dark, gain, read2,
                row_gain[b],
            )  # fmt: skip


@njit(nogil=True, error_model="numpy")
def cell_sums_variance(
    cumulative, x_left, x_right, lo, hi, dark, gain, read2, row_gain, sums, variance
):  # pragma: no cover - compiled
    """A frame's cells in one pass: their sums as float32 (:func:`cell_sums`, the same
    loop, rounded) and the noise model's variance of those float32 sums
    (:func:`cell_variance`): the scan's reading pass, in one pass over the frame."""
    height = cumulative.shape[0] - 1
    width = cumulative.shape[1]
    pixels, bins = lo.shape
    for n in range(pixels):
        for b in range(bins):
            left, right = x_left[n, b], x_right[n, b]
            total = _cell_sum(cumulative, lo[n, b], hi[n, b], left, right)
            raw = np.float32(total)
            sums[n, b] = raw
            t, q = _weights(left, right, float(width))
            variance[n, b] = _variance(
                float(raw), t, q, lo[n, b], hi[n, b], height, dark, gain, read2, row_gain[b]
            )
