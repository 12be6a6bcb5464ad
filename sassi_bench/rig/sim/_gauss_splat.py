"""The compiled loop (numba) that splats correlated Gaussian spots, pixel-integrated.

A design rig's spot changes size, shape and orientation with the SLM point and the
wavelength, so the separable tabulated profiles of :mod:`~sassi_bench.rig.sim._splat`
(one per wavelength) do not apply. Each (open pixel, wavelength sample) here deposits a
Gaussian of its own covariance (cxx, cyy, cxy), integrated over every camera pixel:
exactly along y (the row's share is a difference of normal CDFs), and along x from the
distribution of x given that y falls in the row: a Gaussian centred at
``x + (cxy / cyy) (E[y | row] - y)`` of variance ``cxx - cxy**2 / cyy`` plus
``(cxy / cyy)**2 Var[y | row]`` (y in a row is a truncated normal), again a CDF difference.
That keeps the spot's cross moment exact; the row's x profile is Gaussian where it is
really a mixture, which changes the second moments by far less than 1 %.
Spots are cut at 4 sigma: a spot takes the rows that meet its 4 sigma window. A spot
taller than it is wide is drawn column by column instead (as rows of the transposed
frame, added at the end): a row costs about the same whatever its length, so the
shorter axis sets the work.

A row's x profile (a pixel-integrated 1-D Gaussian of width ``sx`` at sub-pixel phase
``f``) is read from a table of such profiles (:class:`ProfileTable`) at widths in
geometric steps of 2 % and phases every 1/32 px, blended from three of the four
neighbouring (variance, phase) profiles (barycentric in the half of the cell that holds
the point) rather than computed as CDF differences column by column: three contiguous
float32 rows blended is a few vector multiply-adds per column where the CDF was a scalar
table look-up. The blend keeps a profile's sum, mean and variance exact (all three are
linear in phase and in variance), so only its higher moments move: by less than 1e-3 of
the spot's peak (tests/rig/sim/test_gauss_splat.py holds it against the CDF path). Rows
wider or narrower than the table take the CDF path.

The frame is cut into horizontal bands, one task each (the transposed frame's bands are
tasks of the same parallel loop), and each band visits its spots in order, so the frame
is the same bit for bit whatever the number of threads. The spots are binned by band
first (a spot covers a few bands of a pinhole frame), and each spot's first table node
is guessed from the widths' geometric step. A spot's rows in a band are drawn in two
passes: first every row's share and conditional centre and variance (a chain of CDF
look-ups), then every row's profile, so the table reads of one row need not wait for the
next row's look-ups. The loop is compiled with fused multiply-adds allowed
(``fastmath={"contract"}``), which the blend is bound by; a frame moves by about 1e-7 of
its peak.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray
from scipy.special import ndtr

__all__ = ["BANDS", "PAD", "ProfileTable", "profile_table", "splat_gaussians"]

#: Horizontal bands of the frame, one task each.
BANDS = 16
#: Zeros before the widest profile's first tap in the table.
PAD = 8
_TRUNCATE = 4.0
#: Rows of the frame a task adds the transposed frame's columns to.
_TILE = 16
_SQRT1_2 = 1.0 / math.sqrt(2.0)
_INV_SQRT_2PI = 1.0 / math.sqrt(2.0 * math.pi)


# The normal CDF and density tabulated every 1/256 sigma over +-8.5 sigma and
# interpolated linearly (errors < 5e-7 and < 3e-6): the table reads them several times
# faster than math.erf and math.exp.
_CDF_STEP = 1.0 / 256.0
_CDF_REACH = 8.5
_CDF_TABLE = np.array(
    [
        0.5 * (1.0 + math.erf(z * _SQRT1_2))
        for z in np.arange(-_CDF_REACH, _CDF_REACH + _CDF_STEP, _CDF_STEP)
    ]
)
_PDF_TABLE = np.array(
    [
        math.exp(-0.5 * z * z) * _INV_SQRT_2PI
        for z in np.arange(-_CDF_REACH, _CDF_REACH + _CDF_STEP, _CDF_STEP)
    ]
)

# The x-profile table: widths sigma_n = _SIGMA_MIN * _SIGMA_RATIO**n up to _SIGMA_MAX px,
# phases -1/2 + m / _PHASES px.
_SIGMA_MIN = 0.05
_SIGMA_MAX = 8.0
_SIGMA_RATIO = 1.02
_PHASES = 32


@dataclass(frozen=True)
class ProfileTable:
    """Pixel-integrated 1-D Gaussian profiles on a (width, phase) grid.

    ``taps[n, m, centre + j]`` is the share of a unit Gaussian of width ``sigmas[n]``
    centred ``-1/2 + m / phases`` px off pixel 0 that falls in pixel ``j``, for
    ``|j| <= reach[n]`` (``ceil(4 sigma) + 1``, the CDF path's cut) and 0 beyond; the
    zeros run on (``centre`` is at least :data:`PAD` past the first tap, and 8 entries
    follow the last) so a row reads whole float32 vectors from offset 0 of a slice.
    """

    taps: NDArray[np.float32]
    sigmas: NDArray[np.float64]
    reach: NDArray[np.int64]
    centre: int
    phases: int

    @property
    def log_ratio(self) -> float:
        """log of the widths' geometric step."""
        return float(np.log(self.sigmas[1] / self.sigmas[0]))


@lru_cache(maxsize=1)
def profile_table() -> ProfileTable:
    """The x-profile table the splat reads (built once per process, about 2.5 MB).

    Examples
    --------
    >>> table = profile_table()
    >>> n = int(np.searchsorted(table.sigmas, 1.0))
    >>> round(float(table.taps[n, table.phases // 2].sum()), 4)  # a centred spot
    1.0
    """
    count = int(np.ceil(np.log(_SIGMA_MAX / _SIGMA_MIN) / np.log(_SIGMA_RATIO))) + 1
    sigmas = _SIGMA_MIN * _SIGMA_RATIO ** np.arange(count)
    reach = (np.ceil(_TRUNCATE * sigmas) + 1).astype(np.int64)
    widest = int(reach.max())
    centre = PAD + widest
    j = np.arange(-centre, centre + 1, dtype=np.float64)
    phase = -0.5 + np.arange(_PHASES + 1) / _PHASES
    edge = j[None, None, :] - phase[None, :, None]
    s = sigmas[:, None, None]
    taps = ndtr((edge + 0.5) / s) - ndtr((edge - 0.5) / s)
    taps = np.where(np.abs(j)[None, None, :] > reach[:, None, None], 0.0, taps)
    width = (taps.shape[-1] + 8 + 7) // 8 * 8  # 8 zeros after, whole float32 vectors
    padded = np.zeros((count, _PHASES + 1, width), np.float32)
    padded[..., : taps.shape[-1]] = taps
    padded.setflags(write=False)
    return ProfileTable(padded, sigmas, reach, centre, _PHASES)


@njit(inline="always")
def _cdf(t):  # pragma: no cover - compiled
    s = (t + _CDF_REACH) / _CDF_STEP
    if s <= 0.0:
        return 0.0
    if s >= _CDF_TABLE.size - 1:
        return 1.0
    i = int(s)
    f = s - i
    return _CDF_TABLE[i] + f * (_CDF_TABLE[i + 1] - _CDF_TABLE[i])


# The two tables side by side, for rows that need both at the same point.
_CDF_AND_PDF = np.ascontiguousarray(np.stack([_CDF_TABLE, _PDF_TABLE], axis=1))


@njit(inline="always")
def _cdf_and_pdf(t):  # pragma: no cover - compiled
    """The normal CDF and density at ``t`` (their values at +-8.5 beyond), one look-up."""
    s = min(max((t + _CDF_REACH) / _CDF_STEP, 0.0), _CDF_AND_PDF.shape[0] - 1.000001)
    i = int(s)
    f = s - i
    c, d = _CDF_AND_PDF[i, 0], _CDF_AND_PDF[i, 1]
    return c + f * (_CDF_AND_PDF[i + 1, 0] - c), d + f * (_CDF_AND_PDF[i + 1, 1] - d)


@njit(inline="always")
def _variance_node(v, n, variances):  # pragma: no cover - compiled
    """The table's node n with variances[n] <= v < variances[n + 1], searched from ``n``
    (rows of one spot differ by a few nodes at most); -1 outside the table."""
    last = variances.size - 1
    if v < variances[0] or v >= variances[last]:
        return -1
    n = min(max(n, 0), last - 1)  # from a row outside the table: any start
    while variances[n] > v:
        n -= 1
    while variances[n + 1] <= v:
        n += 1
    return n


@njit(inline="always", error_model="numpy")
def _row_by_cdf(row, mx, sx, a, rx, width):  # pragma: no cover - compiled
    """Add ``a`` times the pixel-integrated profile N(mx, sx**2) to ``row``, column by
    column as CDF differences, over ``rx`` columns each side of the centre pixel."""
    cx = round(mx)
    left = max(cx - rx, 0)
    right = min(cx + rx, width - 1)
    lower = _cdf((left - 0.5 - mx) / sx)
    for j in range(left, right + 1):
        upper = _cdf((j + 0.5 - mx) / sx)
        row[j] += np.float32(a * (upper - lower))
        lower = upper


@njit(inline="always", error_model="numpy")
def _row_by_table(frame, i, width, mx, v, n, a, table):  # pragma: no cover - compiled
    """Add ``a`` times the profile N(mx, v) to row ``i`` of the flat frame, blended from
    three of the table's four neighbouring (variance, phase) profiles, variances n and
    n + 1. ``table`` is (taps, flat; its entries a width; a profile; the variances; their
    inverse steps; the reaches; the centre tap; the phases)."""
    taps, per_width, per_profile, variances, inv_steps, reach, centre, phases = table
    wv = (v - variances[n]) * inv_steps[n]  # linear in variance
    cx = round(mx)
    f = (mx - cx + 0.5) * phases
    m = min(int(f), phases - 1)
    wf = f - m
    # barycentric in the half of the (variance, phase) cell that holds the point:
    # corner (n, m) below the diagonal, (n + 1, m + 1) above it, with (n + 1, m) and
    # (n, m + 1); chosen without a branch, which the random halves would mispredict
    k = int(wv + wf > 1.0)
    a_near = np.float32(a * abs(1.0 - wv - wf))
    a_wider = np.float32(a * (k * (1.0 - wf) + (1 - k) * wv))
    a_later = np.float32(a * (k * (1.0 - wv) + (1 - k) * wf))
    r = reach[n + 1]
    left = cx - r
    whole = (2 * r + 8) // 8 * 8
    start = centre - r
    near = (n + k) * per_width + (m + k) * per_profile + start
    wider = (n + 1) * per_width + m * per_profile + start
    later = n * per_width + (m + 1) * per_profile + start
    if left >= 0 and left + whole <= width:
        # whole vectors, every slice of a flat array indexed from 0: numba emits SIMD
        # multiply-adds, and a flat slice is cheaper to take than one of a 3-D table
        t_near = taps[near : near + whole]
        t_wider = taps[wider : wider + whole]
        t_later = taps[later : later + whole]
        window = frame[i * width + left : i * width + left + whole]
        for j in range(whole):
            window[j] += a_near * t_near[j] + a_wider * t_wider[j] + a_later * t_later[j]
    else:  # the frame's edge cuts the spot
        for j in range(max(-r, -cx), min(r, width - 1 - cx) + 1):
            frame[i * width + cx + j] += (
                a_near * taps[near + r + j]
                + a_wider * taps[wider + r + j]
                + a_later * taps[later + r + j]
            )


@njit(error_model="numpy", cache=False)
def _bands_of_spots(y, cyy, weights, height, drawn):  # pragma: no cover - compiled
    """Each band's spots, in (pixel, sample) order: ``spots[starts[b] : starts[b + 1]]``
    are the indices of the spots with rows in band b, of those ``drawn``; ``top`` and
    ``bottom`` are each spot's rows (those that meet its 4 sigma window, in the frame)."""
    n = y.size
    rows_per_band = (height + BANDS - 1) // BANDS
    top = np.empty(n, np.int64)
    bottom = np.empty(n, np.int64)
    counts = np.zeros(BANDS + 1, np.int64)
    for s in range(n):
        # row i spans i - 1/2 .. i + 1/2
        ry = _TRUNCATE * math.sqrt(cyy[s])
        top[s] = max(math.ceil(y[s] - ry - 0.5), 0)
        bottom[s] = min(math.floor(y[s] + ry + 0.5), height - 1)
        if not drawn[s] or weights[s] == 0.0 or top[s] > bottom[s]:
            continue
        for band in range(top[s] // rows_per_band, bottom[s] // rows_per_band + 1):
            counts[band + 1] += 1
    starts = np.cumsum(counts)
    filled = starts[:-1].copy()
    spots = np.empty(starts[-1], np.int64)
    for s in range(n):
        if not drawn[s] or weights[s] == 0.0 or top[s] > bottom[s]:
            continue
        for band in range(top[s] // rows_per_band, bottom[s] // rows_per_band + 1):
            spots[filled[band]] = s
            filled[band] += 1
    return spots, starts, top, bottom


@njit(inline="always", error_model="numpy")
def _draw_band(
    band, spots, frame, bands, taps, variances, inv_steps, reach, centre, phases
):  # pragma: no cover - compiled
    """Draw band ``band`` of ``frame``: the rows there of the spots (x, y, cxx, cyy, cxy,
    weight: the rows of ``spots``) that ``bands`` (:func:`_bands_of_spots`) puts in it."""
    x, y, cxx, cyy, cxy, weights = spots[0], spots[1], spots[2], spots[3], spots[4], spots[5]
    members, starts, tops, bottoms = bands
    height, width = frame.shape
    flat = frame.reshape(-1)
    tabulated = variances.size > 2
    inv_log_step = 1.0 / math.log(variances[1] / variances[0])
    rows_per_band = (height + BANDS - 1) // BANDS
    first = band * rows_per_band
    last = min(height, first + rows_per_band) - 1
    rows = max(last - first + 1, 0)
    per_width = taps.size // variances.size  # the flat table's entries a width
    per_profile = per_width // (phases + 1)  # and a profile
    table = (taps, per_width, per_profile, variances, inv_steps, reach, centre, phases)
    # each spot's rows in two passes: their shares and conditional moments, then their
    # profiles (the table reads then wait on no chain of CDF look-ups)
    mx_row = np.empty(rows)
    v_row = np.empty(rows)
    a_row = np.zeros(rows)
    node_row = np.empty(rows, np.int64)
    for q in range(starts[band], starts[band + 1]):
        s = members[q]
        vy = cyy[s]
        sy = math.sqrt(vy)
        top = max(tops[s], first)
        bottom = min(bottoms[s], last)
        beta = cxy[s] / vy
        vx = max(cxx[s] - cxy[s] * beta, 1e-6)
        # reach: the widest a row's x spread can be (vx plus a row's share of y)
        rx = math.ceil(_TRUNCATE * math.sqrt(vx + beta * beta / 12.0)) + 1
        node = -1
        if tabulated:  # a first guess from the widths' geometric step
            guess = int(math.log(max(vx, variances[0]) / variances[0]) * inv_log_step)
            node = _variance_node(vx, guess, variances)
        # a row's variance is vx plus at most beta**2 / 12 (y within a row varies by at
        # most a uniform's 1/12): where that stays below the next node, so do the rows
        search = tabulated and not (
            node >= 0 and vx + beta * beta / 12.0 + 1e-6 < variances[node + 1]
        )
        inv_sy = 1.0 / sy
        lo = (top - 0.5 - y[s]) * inv_sy
        c_lo, d_lo = _cdf_and_pdf(lo)
        for i in range(top, bottom + 1):
            hi = lo + inv_sy
            c_hi, d_hi = _cdf_and_pdf(hi)
            share = c_hi - c_lo
            r = i - first
            a_row[r] = 0.0
            if share > 1e-12:
                # y within the row: a truncated normal, whose mean and variance carry
                # into x through the correlation
                inv_share = 1.0 / share
                shift = (d_lo - d_hi) * inv_share
                spread = 1.0 + (lo * d_lo - hi * d_hi) * inv_share - shift * shift
                mx_row[r] = x[s] + beta * sy * shift
                v_row[r] = vx + beta * beta * vy * max(spread, 0.0)
                a_row[r] = weights[s] * share
                if search:
                    node = _variance_node(v_row[r], node, variances)
                node_row[r] = node
            lo, c_lo, d_lo = hi, c_hi, d_hi
        for i in range(top, bottom + 1):
            r = i - first
            if a_row[r] == 0.0:
                continue
            if node_row[r] >= 0:
                _row_by_table(flat, i, width, mx_row[r], v_row[r], node_row[r], a_row[r], table)
            else:
                _row_by_cdf(frame[i], mx_row[r], math.sqrt(v_row[r]), a_row[r], rx, width)


@njit(parallel=True, error_model="numpy", cache=False, fastmath={"contract"})
def _splat(spots, swapped, tall, out, taps, variances, reach, centre, phases):  # pragma: no cover
    """Add the spots (6, N: x, y, cxx, cyy, cxy, weight) into ``out``: those not ``tall``
    row by row, the ``tall`` ones (``swapped``: the same with x and y swapped) column by
    column, as rows of the transposed frame, every band of both frames one task of one
    parallel loop; the transposed frame is added in tiles."""
    inv_steps = np.zeros_like(variances)
    inv_steps[:-1] = 1.0 / (variances[1:] - variances[:-1])
    height, width = out.shape
    turned = np.zeros((width, height), np.float32)
    by_rows = _bands_of_spots(spots[1], spots[3], spots[5], height, ~tall)
    by_columns = _bands_of_spots(swapped[1], swapped[3], swapped[5], width, tall)
    for task in prange(2 * BANDS):
        # one call site, so the band's loop is compiled (inlined) once
        by_column = task >= BANDS
        band = np.int64(task) - BANDS if by_column else np.int64(task)
        drawn = swapped if by_column else spots
        frame = turned if by_column else out
        bands = by_columns if by_column else by_rows
        _draw_band(band, drawn, frame, bands, taps, variances, inv_steps, reach, centre, phases)
    tiles = (height + _TILE - 1) // _TILE
    for tile in prange(tiles):
        for i in range(tile * _TILE, min(height, (tile + 1) * _TILE)):
            for j in range(width):
                out[i, j] += turned[j, i]


def splat_gaussians(
    x: NDArray[np.float64],
    y: NDArray[np.float64],
    cxx: NDArray[np.float64],
    cyy: NDArray[np.float64],
    cxy: NDArray[np.float64],
    weights: NDArray[np.float64],
    out: NDArray[np.float32],
    *,
    tabulated: bool = True,
) -> None:
    """Add Gaussian spots (P, K) at centres ``x, y`` with covariances ``cxx, cyy, cxy``
    (camera px, px**2) and energies ``weights`` into ``out`` (H, W, float32, C-ordered),
    in place.

    ``tabulated=False`` computes every row's x profile as CDF differences (the reference
    the table is held against; several times slower).

    Examples
    --------
    >>> out = np.zeros((9, 9), np.float32)
    >>> one = np.ones((1, 1))
    >>> splat_gaussians(4 * one, 4 * one, one, one, 0 * one, one, out)
    >>> round(float(out.sum()), 3)
    1.0
    """
    if not (out.dtype == np.float32 and out.flags.c_contiguous):
        raise ValueError("splat_gaussians: out must be a C-ordered float32 frame")
    spots = np.stack(
        [np.asarray(a, dtype=np.float64).ravel() for a in (x, y, cxx, cyy, cxy, weights)]
    )
    if tabulated:
        table = profile_table()
        taps, sigmas, reach = table.taps.reshape(-1), table.sigmas, table.reach
        centre, phases = table.centre, table.phases
    else:  # two widths, no profiles: every row takes the CDF path
        taps = np.zeros(2 * 2 * 8, np.float32)
        taps.setflags(write=False)  # typed as the table is: one compilation serves both
        sigmas, reach, centre, phases = np.array([1.0, 1.02]), np.zeros(2, np.int64), 0, 1
    # a spot taller than it is wide is drawn column by column, as rows of the transposed
    # frame: a row costs about the same whatever its length, so the shorter axis sets
    # the work
    tall = spots[3] > spots[2]
    swapped = spots[[1, 0, 3, 2, 4, 5]]
    _splat(spots, swapped, tall, out, taps, sigmas**2, reach, centre, phases)
