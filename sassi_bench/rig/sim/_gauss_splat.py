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
Spots are cut at 4 sigma.

A row's x profile (a pixel-integrated 1-D Gaussian of width ``sx`` at sub-pixel phase
``f``) is read from a table of such profiles (:class:`ProfileTable`) at widths in
geometric steps of 2 % and phases every 1/32 px, blended bilinearly in (variance, phase)
rather than computed as CDF differences column by column: four contiguous float32 rows
blended is a few vector multiply-adds per column where the CDF was a scalar table
look-up, about 4x faster over a pinhole frame. The blend keeps a profile's sum, mean and
variance exact (all three are linear in phase and in variance), so only its higher
moments move: by less than 1e-3 of the spot's peak (tests/rig/sim/test_gauss_splat.py
holds it against the CDF path). Rows wider or narrower than the table take the CDF path.

The frame is cut into horizontal bands, one task each, and each band visits its spots in
order, so the frame is the same bit for bit whatever the number of threads. The spots are
binned by band first (a spot covers a few bands of a pinhole frame), and each spot's
first table node is guessed from the widths' geometric step: visiting every spot in every
band and walking the table up from its narrowest width cost about a quarter of a pinhole
frame's splat. The loop is compiled with fused multiply-adds allowed
(``fastmath={"contract"}``), which the four-profile blend is bound by; a frame moves by
about 1e-7 of its peak.
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
BANDS = 32
#: Zeros before the widest profile's first tap in the table.
PAD = 8
_TRUNCATE = 4.0
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


@njit(inline="always")
def _pdf(t):  # pragma: no cover - compiled
    s = (t + _CDF_REACH) / _CDF_STEP
    if s <= 0.0 or s >= _PDF_TABLE.size - 1:
        return 0.0
    i = int(s)
    f = s - i
    return _PDF_TABLE[i] + f * (_PDF_TABLE[i + 1] - _PDF_TABLE[i])


@njit(inline="always")
def _sigma_node(sx, n, sigmas):  # pragma: no cover - compiled
    """The table's node n with sigmas[n] <= sx < sigmas[n + 1], searched from ``n``
    (rows of one spot differ by a few nodes at most); -1 outside the table."""
    last = sigmas.size - 1
    if sx < sigmas[0] or sx >= sigmas[last]:
        return -1
    n = min(max(n, 0), last - 1)  # from a row outside the table: any start
    while sigmas[n] > sx:
        n -= 1
    while sigmas[n + 1] <= sx:
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
def _row_by_table(
    row, mx, sx, n, a, width, taps, sigmas, reach, centre, phases
):  # pragma: no cover - compiled
    """Add ``a`` times the profile N(mx, sx**2) to ``row``, blended from the table's four
    neighbouring (width, phase) profiles, widths n and n + 1."""
    s0, s1 = sigmas[n], sigmas[n + 1]
    wv = (sx * sx - s0 * s0) / (s1 * s1 - s0 * s0)  # linear in variance
    cx = round(mx)
    f = (mx - cx + 0.5) * phases
    m = min(int(f), phases - 1)
    wf = f - m
    a00 = np.float32(a * (1.0 - wv) * (1.0 - wf))
    a01 = np.float32(a * (1.0 - wv) * wf)
    a10 = np.float32(a * wv * (1.0 - wf))
    a11 = np.float32(a * wv * wf)
    r = reach[n + 1]
    left = cx - r
    whole = (2 * r + 8) // 8 * 8
    if left >= 0 and left + whole <= width:
        # whole vectors, every slice indexed from 0: numba emits SIMD multiply-adds
        start = centre - r
        t00 = taps[n, m, start : start + whole]
        t01 = taps[n, m + 1, start : start + whole]
        t10 = taps[n + 1, m, start : start + whole]
        t11 = taps[n + 1, m + 1, start : start + whole]
        window = row[left : left + whole]
        for j in range(whole):
            window[j] += a00 * t00[j] + a01 * t01[j] + a10 * t10[j] + a11 * t11[j]
    else:  # the frame's edge cuts the spot
        for j in range(max(-r, -cx), min(r, width - 1 - cx) + 1):
            k = centre + j
            row[cx + j] += (
                a00 * taps[n, m, k]
                + a01 * taps[n, m + 1, k]
                + a10 * taps[n + 1, m, k]
                + a11 * taps[n + 1, m + 1, k]
            )


@njit(error_model="numpy", cache=False)
def _bands_of_spots(y, cyy, weights, height):  # pragma: no cover - compiled
    """Each band's spots, in (pixel, sample) order: ``spots[starts[b] : starts[b + 1]]``
    are the flat indices of the spots with rows in band b; ``top`` and ``bottom`` are
    each spot's rows (the 4 sigma cut, in the frame)."""
    n = y.size
    yf, vf, wf = y.ravel(), cyy.ravel(), weights.ravel()
    rows_per_band = (height + BANDS - 1) // BANDS
    top = np.empty(n, np.int64)
    bottom = np.empty(n, np.int64)
    counts = np.zeros(BANDS + 1, np.int64)
    for s in range(n):
        ry = math.ceil(_TRUNCATE * math.sqrt(vf[s])) + 1
        cy = round(yf[s])
        top[s] = max(cy - ry, 0)
        bottom[s] = min(cy + ry, height - 1)
        if wf[s] == 0.0 or top[s] > bottom[s]:
            continue
        for band in range(top[s] // rows_per_band, bottom[s] // rows_per_band + 1):
            counts[band + 1] += 1
    starts = np.cumsum(counts)
    filled = starts[:-1].copy()
    spots = np.empty(starts[-1], np.int64)
    for s in range(n):
        if wf[s] == 0.0 or top[s] > bottom[s]:
            continue
        for band in range(top[s] // rows_per_band, bottom[s] // rows_per_band + 1):
            spots[filled[band]] = s
            filled[band] += 1
    return spots, starts, top, bottom


@njit(parallel=True, error_model="numpy", cache=False, fastmath={"contract"})
def _splat(
    x, y, cxx, cyy, cxy, weights, out, taps, sigmas, reach, centre, phases
):  # pragma: no cover - compiled
    """Add Gaussian spots (P, K) into ``out``; a table of no widths takes the CDF path
    for every row."""
    height, width = out.shape
    rows_per_band = (height + BANDS - 1) // BANDS
    tabulated = taps.shape[0] > 1
    inv_log_step = 1.0 / math.log(sigmas[1] / sigmas[0])
    spots, starts, tops, bottoms = _bands_of_spots(y, cyy, weights, height)
    xf, yf, cxxf, cyyf, cxyf, wf = (
        x.ravel(),
        y.ravel(),
        cxx.ravel(),
        cyy.ravel(),
        cxy.ravel(),
        weights.ravel(),
    )
    for band in prange(BANDS):
        first = band * rows_per_band
        last = min(height, first + rows_per_band) - 1
        for q in range(starts[band], starts[band + 1]):
            s = spots[q]
            w = wf[s]
            vy = cyyf[s]
            sy = math.sqrt(vy)
            top = max(tops[s], first)
            bottom = min(bottoms[s], last)
            beta = cxyf[s] / vy
            vx = max(cxxf[s] - cxyf[s] * beta, 1e-6)
            # reach: the widest a row's x spread can be (vx plus a row's share of y)
            rx = math.ceil(_TRUNCATE * math.sqrt(vx + beta * beta / 12.0)) + 1
            node = -1
            if tabulated:  # a first guess from the widths' geometric step
                sx0 = math.sqrt(vx)
                guess = int(math.log(max(sx0, sigmas[0]) / sigmas[0]) * inv_log_step)
                node = _sigma_node(sx0, guess, sigmas)
            inv_sy = 1.0 / sy
            lo = (top - 0.5 - yf[s]) * inv_sy
            c_lo, d_lo = _cdf(lo), _pdf(lo)
            for i in range(top, bottom + 1):
                hi = lo + inv_sy
                c_hi, d_hi = _cdf(hi), _pdf(hi)
                share = c_hi - c_lo
                if share > 1e-12:
                    # y within the row: a truncated normal, whose mean and variance
                    # carry into x through the correlation
                    inv_share = 1.0 / share
                    shift = (d_lo - d_hi) * inv_share
                    spread = 1.0 + (lo * d_lo - hi * d_hi) * inv_share - shift * shift
                    mx = xf[s] + beta * sy * shift
                    sx = math.sqrt(vx + beta * beta * vy * max(spread, 0.0))
                    a = w * share
                    if tabulated:
                        node = _sigma_node(sx, node, sigmas)
                    if node >= 0:
                        _row_by_table(
                            out[i],
                            mx,
                            sx,
                            node,
                            a,
                            width,
                            taps,
                            sigmas,
                            reach,
                            centre,
                            phases,
                        )
                    else:
                        _row_by_cdf(out[i], mx, sx, a, rx, width)
                lo, c_lo, d_lo = hi, c_hi, d_hi


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
    (camera px, px**2) and energies ``weights`` into ``out`` (H, W, float32), in place.

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
    arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (x, y, cxx, cyy, cxy, weights)]
    if tabulated:
        table = profile_table()
        taps, sigmas, reach = table.taps, table.sigmas, table.reach
        centre, phases = table.centre, table.phases
    else:
        taps = np.zeros((1, 2, 8), np.float32)
        sigmas, reach, centre, phases = np.array([1.0, 1.02]), np.zeros(1, np.int64), 0, 1
    _splat(*arrays, out, taps, sigmas, reach, centre, phases)
