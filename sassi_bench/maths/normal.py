"""The normal distribution's integrals a Gaussian spot needs, in numpy and compiled.

A spot blurred by a Gaussian and integrated over camera pixels is a sum of normal CDFs
(its share of a row interval), of ramps ``R(t) = t Phi(t) + phi(t)`` (a box of light
blurred and integrated over a box of columns: :func:`box_overlap`) and, for one SLM
pixel's image integrated by a camera pixel, of the same ramps at four offsets
(:func:`pixel_spot`). The compiled loops evaluate the CDF from a table of cubic pieces
(:data:`NORMAL_CDF_TABLE`, :func:`tabulated_cdf`): the row unmixing evaluates millions
of them per prototype frame, and a table lookup costs a fraction of ``math.erfc``
(``docs/notes/2026-12-01-measured-in-code-comments.md``). Any location-scale profile with a
CDF and a density can be tabulated the same way (:func:`cdf_table`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray
from scipy.special import ndtr

__all__ = [
    "CDF_RANGE",
    "CDF_STEPS_PER_UNIT",
    "NORMAL_CDF_TABLE",
    "box_overlap",
    "cdf_table",
    "normal_density",
    "pixel_spot",
    "ramp",
    "tabulated_cdf",
]

#: A tabulated CDF covers [-CDF_RANGE, CDF_RANGE] in pieces of 1 / CDF_STEPS_PER_UNIT.
CDF_RANGE = 9.0
CDF_STEPS_PER_UNIT = 64.0

_SQRT_2PI = np.sqrt(2.0 * np.pi)


def normal_density(z: ArrayLike) -> NDArray[np.float64]:
    """The standard normal density.

    Examples
    --------
    >>> round(float(normal_density(0.0)), 6)
    0.398942
    """
    z = np.asarray(z, dtype=np.float64)
    return np.exp(-0.5 * z * z) / _SQRT_2PI


def cdf_table(
    cdf: Callable[[NDArray], NDArray], density: Callable[[NDArray], NDArray]
) -> NDArray[np.float64]:
    """A CDF as piecewise cubics for :func:`tabulated_cdf`: row ``i`` holds the coefficients,
    in the piece's local coordinate ``u`` in [0, 1), of the cubic Hermite interpolant of the
    values and slopes at its ends.

    Examples
    --------
    >>> table = cdf_table(ndtr, normal_density)
    >>> table.shape, bool(np.array_equal(table, NORMAL_CDF_TABLE))
    ((1152, 4), True)
    """
    z = np.arange(-CDF_RANGE, CDF_RANGE + 0.5 / CDF_STEPS_PER_UNIT, 1.0 / CDF_STEPS_PER_UNIT)
    value = cdf(z)
    slope = density(z) / CDF_STEPS_PER_UNIT  # per piece
    v0, v1, d0, d1 = value[:-1], value[1:], slope[:-1], slope[1:]
    return np.stack([v0, d0, 3.0 * (v1 - v0) - 2.0 * d0 - d1, 2.0 * (v0 - v1) + d0 + d1], 1)


#: The standard normal CDF as cubic pieces (errors under 1e-10).
NORMAL_CDF_TABLE = cdf_table(ndtr, normal_density)


@njit(nogil=True, error_model="numpy")
def tabulated_cdf(z, table):  # pragma: no cover - compiled
    """A CDF at ``z`` from its :func:`cdf_table`; 0 below the table, 1 above, NaN stays NaN.

    Examples
    --------
    >>> round(tabulated_cdf(1.0, NORMAL_CDF_TABLE), 9) == round(float(ndtr(1.0)), 9)
    True
    """
    t = (z + CDF_RANGE) * CDF_STEPS_PER_UNIT
    if t != t:
        return t
    if t <= 0.0:
        return 0.0
    if t >= table.shape[0]:  # also +inf, before the conversion to an index
        return 1.0
    i = int(t)
    u = t - i
    return table[i, 0] + u * (table[i, 1] + u * (table[i, 2] + u * table[i, 3]))


def ramp(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """The normal CDF's antiderivative ``z Phi(z) + phi(z)``.

    Examples
    --------
    >>> round(float(ramp(np.array(0.0))), 6), round(float(ramp(np.array(10.0))), 6)
    (0.398942, 10.0)
    """
    return z * ndtr(z) + np.exp(-0.5 * z * z) / np.sqrt(2.0 * np.pi)


def box_overlap(x_left, x_right, sigma) -> NDArray[np.float64]:
    """Share of light spread evenly over box ``b'`` (``[x_left, x_right]``, camera columns)
    and blurred by a Gaussian of ``sigma[..., b']`` that lands in box ``b``:
    ``A[..., b, b']``.

    Examples
    --------
    >>> a = box_overlap(np.array([0.0, 1.0]), np.array([1.0, 2.0]), np.array([1e-6, 1e-6]))
    >>> a.round(3).tolist()
    [[1.0, 0.0], [0.0, 1.0]]
    """
    x0, x1 = x_left[..., :, None], x_right[..., :, None]
    s0, s1 = x_left[..., None, :], x_right[..., None, :]
    sg = np.broadcast_to(sigma, x_left.shape)[..., None, :]
    width = s1 - s0
    return (sg / width) * (
        ramp((x1 - s0) / sg) - ramp((x1 - s1) / sg) - ramp((x0 - s0) / sg) + ramp((x0 - s1) / sg)
    )


def pixel_spot(
    offset: ArrayLike, aperture_px: float, sigma_px: ArrayLike
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """One SLM pixel's spot as a camera pixel records it, and its two derivatives.

    The spot is a box of side ``aperture_px`` (the SLM pixel's image), convolved with a
    box of one camera pixel and a Gaussian of ``sigma_px``, at ``offset`` px from its
    centre, in closed form: with ``R(t) = t Φ(t/σ) + σ φ(t/σ)`` (the smoothed ramp),
    ``h(d) = [R(d + a⁺) − R(d + a⁻) − R(d − a⁻) + R(d − a⁺)] / aperture``,
    ``a± = (aperture ± 1) / 2``; ``dR/dt = Φ`` and ``dR/dσ = φ``.

    Returns
    -------
    value, slope, width_slope : ndarray
        The spot (it sums to one over whole-pixel steps), its derivative with respect to
        ``offset`` and with respect to ``sigma_px``.

    Examples
    --------
    >>> x = np.arange(-12, 13)
    >>> value, slope, width = pixel_spot(x + 0.3, 1.0, 1.5)
    >>> round(float(value.sum()), 6), bool(abs(slope.sum()) < 1e-9), bool(abs(width.sum()) < 1e-9)
    (1.0, True, True)
    >>> h = 1e-6
    >>> up, down = pixel_spot(0.4 + h, 1.0, 0.8)[0], pixel_spot(0.4 - h, 1.0, 0.8)[0]
    >>> bool(abs((up - down) / (2 * h) - pixel_spot(0.4, 1.0, 0.8)[1]) < 1e-6)
    True
    """
    d = np.asarray(offset, dtype=np.float64)
    sigma = np.maximum(np.asarray(sigma_px, dtype=np.float64), 1e-3)
    half_sum, half_diff = (aperture_px + 1.0) / 2.0, (aperture_px - 1.0) / 2.0
    value = slope = width = 0.0
    for shift, sign in ((half_sum, 1.0), (half_diff, -1.0), (-half_diff, -1.0), (-half_sum, 1.0)):
        t = d + shift
        z = t / sigma
        cdf = ndtr(z)
        density = np.exp(-0.5 * z * z) / _SQRT_2PI
        value = value + sign * (t * cdf + sigma * density)
        slope = slope + sign * cdf
        width = width + sign * density
    return value / aperture_px, slope / aperture_px, width / aperture_px
