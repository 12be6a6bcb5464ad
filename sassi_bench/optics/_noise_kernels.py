"""Compiled sensor noise (numba): exact Poisson shot noise, Gaussian read noise, the ADC.

:meth:`~sassi_bench.optics.sensor.SensorModel.expose` draws a frame in bands of rows; each
band is one call of :func:`expose_band`, which draws and digitises the band's pixels in
one pass, in row-major order, from the band's own random stream.

* **Random bits**: SFC64 (Chris Doty-Humphrey's Small Fast Chaotic generator, numpy's
  ``np.random.SFC64``), seeded as numpy seeds it from a ``SeedSequence`` (three words,
  counter 1, twelve outputs discarded): a band's stream is numpy's SFC64 stream of that
  seed, bit for bit (tested).
* **Poisson**, exact:

  - below :data:`TABLE_MAX`, ``lam = m / 4 + d`` with ``d < 1/4`` (counts of independent
    means add): the count of mean ``m / 4`` by inversion of its tabulated CDF, started by
    a guide table (Chen & Asau 1974: on average under two comparisons), plus the count
    of mean ``d`` by inversion (``u <= 1 - d``, which implies ``u <= exp(-d)``, gives 0
    without an ``exp`` three times in four). Each table spans its mean +- 12 standard
    deviations (+ 30 above): what it leaves out has a probability below 1e-25, far below
    the 2**-53 resolution of the uniform draw. The tables take 0.2 MB and stay in cache.
  - from :data:`TABLE_MAX` up, Ahrens & Dieter's PD ("Computer generation of Poisson
    deviates from modified normal distributions", *ACM TOMS* 8, 1982): a normal deviate
    rounded down is accepted at once when it is at least ``lam - 1.1484`` (about half the
    draws) or passes a cubic squeeze (most of the rest); the few others go through the
    exact acceptance tests against the Poisson pmf. The pmf is evaluated to double
    precision (``k (log1p(v) - v) - stirlerr(k) - log(2 pi k) / 2`` with ``v = (lam - k) / k``
    and the Stirling series' error term from a table below 16 and 5 terms above, as in
    Loader 2000), not with PD's published 7-digit polynomial and 2-term Stirling
    series, so the acceptance is exact to double precision.

  Why PD rather than tables for large means (tabulated counts of multiples of 256 plus
  a fine table of the remainder): a calibration frame's means vary from pixel to pixel,
  so the remainder would pick a table at random among megabytes of them, and the cache
  misses cost more than PD's few operations, whatever the means
  (``benchmarks/bench_render.py``; the figures:
  ``docs/notes/2026-12-01-measured-in-code-comments.md``).
* **Normal**: the 256-layer ziggurat of Marsaglia & Tsang (2000) with numpy's layer
  constants and numpy's use of the 64 bits.

The tables are module constants, frozen into the compiled code: passed as arguments to
the inlined draw functions they cost an array reference count per call, more than the
draw itself.

Why not numpy: numpy's ``Generator.poisson`` evaluates ``loggam`` and broadcasts per
pixel, and its ``standard_normal`` and the digitisation go through whole-frame
temporaries: several times this loop's CPU
(``docs/notes/2026-12-01-measured-in-code-comments.md``).

No on-disk cache: numba's cache pickles into the package folder (see
:mod:`sassi_bench.spectra._kernels`); the first frame of a process compiles (a few s).
"""

from __future__ import annotations

import math

import numba
import numpy as np
from scipy.special import gammaln

__all__ = [
    "TABLE_MAX",
    "expose_band",
    "poisson_draws",
    "poisson_log_pmf",
    "seed_state",
    "sfc64_raw",
    "standard_normal_draws",
]

_JIT = {"cache": False, "nogil": True, "error_model": "numpy"}

#: Means below this are drawn from tables in steps of 1/4; from it up, by PD.
TABLE_MAX = 32.0
_FINE_PER_UNIT = 4  # fine tables per unit of mean
_SIGMAS = 12.0

_U1 = np.uint64(1)
_U3 = np.uint64(3)
_U8 = np.uint64(8)
_U11 = np.uint64(11)
_U24 = np.uint64(24)
_U40 = np.uint64(40)
_LOW_BYTE = np.uint64(0xFF)
_MANTISSA = np.uint64(0x000FFFFFFFFFFFFF)
_TO_DOUBLE = 1.0 / 9007199254740992.0  # 2**-53


def _cdf_tables(means: np.ndarray) -> tuple[np.ndarray, ...]:
    """Poisson CDF tables of ``means``, concatenated: ``(cdf, guide, start, low)``.

    Table ``m`` holds ``P(X <= low[m] + k)`` at ``cdf[start[m] + k]`` (its last entry set
    to 1), and ``guide[start[m] + j]`` is the first ``k`` whose CDF exceeds ``j / n``
    (``n`` the table's length). The probabilities are summed in order from the lower end
    of the table, in double precision.
    """
    sd = np.sqrt(means)
    low = np.maximum(0, np.floor(means - _SIGMAS * sd - 10.0)).astype(np.int64)
    high = np.ceil(means + _SIGMAS * sd + 30.0).astype(np.int64)
    lengths = high - low + 1
    start = np.concatenate([[0], np.cumsum(lengths)]).astype(np.int64)
    which = np.repeat(np.arange(means.size), lengths)
    offset = np.arange(start[-1]) - start[which]
    k = (offset + low[which]).astype(np.float64)
    lam = means[which]
    with np.errstate(divide="ignore", invalid="ignore"):
        log_pmf = np.where(lam > 0, k * np.log(lam) - lam - gammaln(k + 1.0), -np.inf)
    log_pmf[(lam == 0) & (k == 0)] = 0.0
    pmf = np.exp(log_pmf)
    cdf = np.empty_like(pmf)
    guide = np.empty(start[-1], np.int32)
    for m in range(means.size):
        table = slice(start[m], start[m + 1])
        cdf[table] = np.cumsum(pmf[table])
        cdf[start[m + 1] - 1] = 1.0
        guide[table] = np.searchsorted(cdf[table], offset[table] / lengths[m], side="right")
    return cdf, guide, start, low


_FINE_CDF, _FINE_GUIDE, _FINE_START, _FINE_LOW = _cdf_tables(
    np.arange(0.0, TABLE_MAX, 1.0 / _FINE_PER_UNIT)
)
_LOG_SQRT_2PI = 0.5 * math.log(2.0 * math.pi)
#: Stirling's error term ``log k! - (k + 1/2) log k + k - log(2 pi) / 2`` for k < 16 (k = 0
#: unused); above, its series to the k**-9 term is exact to double precision.
_STIRLING_ERROR = np.array(
    [0.0] + [gammaln(k + 1.0) - ((k + 0.5) * math.log(k) - k + _LOG_SQRT_2PI) for k in range(1, 16)]
)


def _ziggurat_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 256-layer normal ziggurat with numpy's constants: ``ki`` (uint64), ``wi``, ``fi``.

    Layer edges ``x`` (ascending) enclose equal areas ``v`` under ``exp(-x^2 / 2)`` with
    the tail from ``r``; ``ki`` is the share of each layer inside the layer above, in
    52-bit fixed point; ``wi`` scales 52 bits to a layer's width; ``fi`` is the density
    at each edge.
    """
    size = 256

    def pdf(t):
        return np.exp(-0.5 * t * t)

    x = np.zeros(size)
    x[0] = _ZIG_R
    for i in range(1, size - 1):
        x[i] = np.sqrt(-2 * np.log(pdf(x[i - 1]) + _ZIG_V / x[i - 1]))
    x = x[::-1]
    scale = 2**52
    ki = np.zeros(size, np.uint64)
    ki[1:] = np.round(x[:-1] / x[1:] * scale).astype(np.uint64)
    ki[0] = np.uint64(np.round(((x.max() * pdf(x.max())) / _ZIG_V) * scale))
    wi = x.copy()
    wi[0] = _ZIG_V / pdf(x.max())
    return ki, wi / scale, pdf(x)


_ZIG_R = 3.6541528853610087963519472518
_ZIG_INV_R = 0.27366123732975827203338247596
_ZIG_V = 0.0049286732339746519
_ZIG_KI, _ZIG_WI, _ZIG_FI = _ziggurat_tables()


def seed_state(seed_sequence: np.random.SeedSequence) -> np.ndarray:
    """The SFC64 state numpy makes from ``seed_sequence``: words a, b, c and the counter.

    Examples
    --------
    >>> state = seed_state(np.random.SeedSequence(5))
    >>> mine = sfc64_raw(state, 3)
    >>> numpys = np.random.SFC64(np.random.SeedSequence(5)).random_raw(3)
    >>> mine.tolist() == numpys.tolist()
    True
    """
    state = np.empty(4, np.uint64)
    state[:3] = seed_sequence.generate_state(3, np.uint64)
    state[3] = 1
    sfc64_raw(state, 12)
    return state


# The generator's state travels through the compiled functions as a tuple (a, b, c,
# counter), so it stays in registers: kept in an array, every draw would wait on a store
# and a load.


@numba.njit(inline="always", **_JIT)
def _next64(s):  # pragma: no cover - compiled
    a, b, c, w = s
    out = a + b + w
    return out, (b ^ (b >> _U11), c + (c << _U3), ((c << _U24) | (c >> _U40)) + out, w + _U1)


@numba.njit(inline="always", **_JIT)
def _next_double(s):  # pragma: no cover - compiled
    bits, s = _next64(s)
    return np.float64(bits >> _U11) * _TO_DOUBLE, s


@numba.njit(inline="always", **_JIT)
def _load(state):  # pragma: no cover - compiled
    return (state[0], state[1], state[2], state[3])


@numba.njit(inline="always", **_JIT)
def _store(state, s):  # pragma: no cover - compiled
    state[0], state[1], state[2], state[3] = s


@numba.njit(**_JIT)
def sfc64_raw(state, n):  # pragma: no cover - compiled
    """``n`` raw 64-bit outputs of the SFC64 ``state`` (advanced in place)."""
    out = np.empty(n, np.uint64)
    s = _load(state)
    for i in range(n):
        out[i], s = _next64(s)
    _store(state, s)
    return out


@numba.njit(inline="always", **_JIT)
def _normal(s):  # pragma: no cover - compiled
    """One standard normal draw (the ziggurat; numpy's use of the bits)."""
    while True:
        bits, s = _next64(s)
        idx = np.intp(bits & _LOW_BYTE)
        bits >>= _U8
        rabs = (bits >> _U1) & _MANTISSA
        x = np.float64(rabs) * _ZIG_WI[idx]
        if bits & _U1:
            x = -x
        if rabs < _ZIG_KI[idx]:
            return x, s
        if idx == 0:  # the tail beyond r, by Marsaglia's exponential method
            while True:
                u1, s = _next_double(s)
                u2, s = _next_double(s)
                xx = -_ZIG_INV_R * math.log1p(-u1)
                yy = -math.log1p(-u2)
                if yy + yy > xx * xx:
                    if (rabs >> _U8) & _U1:
                        return -(_ZIG_R + xx), s
                    return _ZIG_R + xx, s
        else:
            u, s = _next_double(s)
            if (_ZIG_FI[idx - 1] - _ZIG_FI[idx]) * u + _ZIG_FI[idx] < math.exp(-0.5 * x * x):
                return x, s


@numba.njit(inline="always", **_JIT)
def _stirling_error(k):  # pragma: no cover - compiled
    """``log k! - (k + 1/2) log k + k - log(2 pi) / 2`` for an integer ``k >= 1``."""
    if k < 16:
        return _STIRLING_ERROR[k]
    n = np.float64(k)
    nn = n * n
    return (
        1.0 / 12.0
        - (1.0 / 360.0 - (1.0 / 1260.0 - (1.0 / 1680.0 - 1.0 / (1188.0 * nn)) / nn) / nn) / nn
    ) / n


@numba.njit(inline="always", **_JIT)
def _log_pmf(k, lam):  # pragma: no cover - compiled
    """``log P(X = k)`` for X ~ Poisson(lam > 0), ``k >= 0``, to double precision: the
    large terms of ``k log lam - lam - log k!`` cancel analytically."""
    if k == 0:
        return -lam
    fk = np.float64(k)
    v = (lam - fk) / fk
    return fk * (math.log1p(v) - v) - _stirling_error(k) - 0.5 * math.log(fk) - _LOG_SQRT_2PI


@numba.njit(inline="always", **_JIT)
def _poisson_pd(s, lam):  # pragma: no cover - compiled
    """One Poisson draw of mean ``lam >= 10`` by Ahrens & Dieter's PD (see the notes)."""
    root = math.sqrt(lam)
    t, s = _normal(s)
    g = lam + root * t
    k = np.int64(0)
    u = 0.0
    if g >= 0.0:
        k = np.int64(math.floor(g))
        if k >= np.int64(math.floor(lam - 1.1484)):  # step N: immediate acceptance
            return k, s
        u, s = _next_double(s)
        diff = lam - np.float64(k)
        if 6.0 * lam * lam * u >= diff * diff * diff:  # step S: the squeeze
            return k, s
    # Step P: the hat's coefficients (an Edgeworth-corrected normal density).
    omega = 0.3989422804014327 / root
    b1 = 1.0 / (24.0 * lam)
    b2 = 0.3 * b1 * b1
    c3 = b1 * b2 / 7.0
    c2 = b2 - 15.0 * c3
    c1 = b1 - 6.0 * b2 + 45.0 * c3
    c0 = 1.0 - b1 + 3.0 * b2 - 15.0 * c3
    c = 0.1069 / lam
    if g >= 0.0:  # step Q: the exact test of the normal sample
        x = (np.float64(k) + 0.5 - lam) / root
        xx = x * x
        fy = omega * (((c3 * xx + c2) * xx + c1) * xx + c0)
        if fy - u * fy <= math.exp(_log_pmf(k, lam) + 0.5 * xx):
            return k, s
    while True:  # step E: a double-exponential sample, and step H: its exact test
        e, s = _next_double(s)
        e = -math.log1p(-e)
        u, s = _next_double(s)
        u = 2.0 * u - 1.0
        t = 1.8 + (e if u >= 0.0 else -e)
        if t <= -0.6744:
            continue
        k = np.int64(math.floor(lam + root * t))
        x = (np.float64(k) + 0.5 - lam) / root
        xx = x * x
        fy = omega * (((c3 * xx + c2) * xx + c1) * xx + c0)
        if c * abs(u) <= math.exp(_log_pmf(k, lam) + e) - fy * math.exp(e - 0.5 * xx):
            return k, s


@numba.njit(inline="always", **_JIT)
def _poisson_below_quarter(s, lam):  # pragma: no cover - compiled
    """One Poisson draw of a mean below 1/4 by inversion (``u <= 1 - lam`` implies
    ``u <= exp(-lam)``, so ``exp`` is needed only when ``u > 1 - lam``)."""
    u, s = _next_double(s)
    if u <= 1.0 - lam:
        return np.int64(0), s
    p = math.exp(-lam)
    cdf = p
    k = np.int64(0)
    # P(k > 30) < 1e-40 for lam < 1/4: the bound only stops round-off from looping.
    while u > cdf and k < 30:
        k += 1
        p *= lam / k
        cdf += p
    return k, s


@numba.njit(inline="always", **_JIT)
def _fine_table(s, m):  # pragma: no cover - compiled
    """A draw of mean ``m / 4`` (``m >= 1``) from its tabulated CDF."""
    u, s = _next_double(s)
    first = _FINE_START[m]
    k = np.int64(_FINE_GUIDE[first + np.intp(u * (_FINE_START[m + 1] - first))])
    while _FINE_CDF[first + k] <= u:
        k += 1
    return _FINE_LOW[m] + k, s


@numba.njit(inline="always", **_JIT)
def _poisson(s, lam):  # pragma: no cover - compiled
    """One Poisson draw of mean ``lam`` (>= 0, finite; see the module's notes)."""
    if lam >= TABLE_MAX:
        return _poisson_pd(s, lam)
    count = np.int64(0)
    m = np.intp(lam * _FINE_PER_UNIT)
    if m > 0:
        part, s = _fine_table(s, m)
        count += part
        lam -= m * (1.0 / _FINE_PER_UNIT)
    part, s = _poisson_below_quarter(s, lam)
    return count + part, s


@numba.njit(**_JIT)
def expose_band(
    rate, out, state, dark, exposure, read_noise, full_well, gain, offset, max_adu
):  # pragma: no cover - compiled
    """Draw and digitise one band of rows: ``rate`` (rows, n) e-/s -> ``out`` (rows, n).

    Each pixel, in row-major order, draws its Poisson count of mean
    ``max(rate + dark, 0) * exposure`` and then one standard normal ``z``, from
    ``state`` (advanced in place):

        e = min(count + read_noise * z, full_well);  out = clip(rint(e / gain + offset))

    Returns
    -------
    int
        0, or 1 if a mean was NaN or beyond 1e18 (the band is then incomplete).
    """
    s = _load(state)
    rows, cols = rate.shape
    for i in range(rows):
        for j in range(cols):
            lam = (np.float64(rate[i, j]) + dark) * exposure
            if not lam > 0.0:
                if lam != lam:
                    _store(state, s)
                    return 1
                lam = 0.0
            elif lam > 1e18:  # no int64 count
                _store(state, s)
                return 1
            count, s = _poisson(s, lam)
            z, s = _normal(s)
            e = np.float64(count) + read_noise * z
            if e > full_well:
                e = full_well
            adu = np.rint(e / gain + offset)
            if adu < 0.0:
                adu = 0.0
            elif adu > max_adu:
                adu = max_adu
            out[i, j] = adu
    _store(state, s)
    return 0


@numba.njit(**_JIT)
def poisson_draws(state, lam):  # pragma: no cover - compiled
    """Poisson draws of the means ``lam`` (1-D, >= 0) from ``state``, in order."""
    out = np.empty(lam.size, np.int64)
    s = _load(state)
    for i in range(lam.size):
        out[i], s = _poisson(s, lam[i])
    _store(state, s)
    return out


@numba.njit(**_JIT)
def poisson_log_pmf(k, lam):  # pragma: no cover - compiled
    """``log P(X = k[i])`` for X ~ Poisson(``lam[i]``) (1-D arrays; ``lam > 0``), as the
    sampler evaluates it."""
    out = np.empty(lam.size)
    for i in range(lam.size):
        out[i] = _log_pmf(k[i], lam[i])
    return out


@numba.njit(**_JIT)
def standard_normal_draws(state, n):  # pragma: no cover - compiled
    """``n`` standard normal draws from ``state``."""
    out = np.empty(n)
    s = _load(state)
    for i in range(n):
        out[i], s = _normal(s)
    _store(state, s)
    return out
