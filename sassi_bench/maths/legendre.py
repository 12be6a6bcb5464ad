"""The 2-D Legendre field basis over the SLM, and power series in a spectral variable.

The calibration describes every smooth function of the SLM field (the dispersion's
coefficients, one laser's SLM -> camera map) in one basis, which is part of the bundle's
model contract (:mod:`sassi_bench.bundle.models`):

* field coordinates ``û = 2u / (W − 1) − 1``, ``v̂ = 2v / (H − 1) − 1`` (−1..1 over an
  SLM of ``H`` rows and ``W`` columns; :func:`field_coordinates`);
* the products ``P_i(û) P_j(v̂)`` of Legendre polynomials for all ``i + j <= D``, ordered
  by total degree, then ``i`` descending (:func:`legendre2d_terms`,
  :func:`legendre2d_design`).

A coefficient that is itself a polynomial in a spectral variable ``s`` is evaluated with
:func:`horner`.

Examples
--------
>>> u_hat, v_hat = field_coordinates(639, 0, (400, 640))
>>> legendre2d_design(u_hat, v_hat, 1).tolist()  # P0 P0, P1(û) P0, P0 P1(v̂)
[1.0, 1.0, -1.0]
"""

from __future__ import annotations

import numbers

import numpy as np
from numpy.polynomial import legendre
from numpy.typing import ArrayLike, NDArray

__all__ = ["field_coordinates", "horner", "legendre2d_design", "legendre2d_terms"]


def legendre2d_terms(degree: int) -> tuple[tuple[int, int], ...]:
    """Exponent pairs ``(i, j)`` of the 2D Legendre basis ``P_i(û) P_j(v̂)``, ``i + j <= degree``.

    Ordered by total degree ``i + j``, then by ``i`` descending.

    Parameters
    ----------
    degree
        Maximum total degree ``D >= 0``.

    Returns
    -------
    tuple of (int, int)
        ``(D + 1)(D + 2) / 2`` pairs.

    Raises
    ------
    ValueError
        If ``degree`` is not an integer >= 0.

    Examples
    --------
    >>> legendre2d_terms(2)
    ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    """
    if isinstance(degree, bool) or not isinstance(degree, numbers.Integral) or degree < 0:
        raise ValueError(f"legendre2d degree must be an integer >= 0, got {degree!r}")
    return tuple((i, total - i) for total in range(int(degree) + 1) for i in range(total, -1, -1))


def legendre2d_design(u_hat: ArrayLike, v_hat: ArrayLike, degree: int) -> NDArray[np.float64]:
    """Design matrix of the 2D Legendre field basis.

    Parameters
    ----------
    u_hat, v_hat
        Normalised field coordinates (−1..1 over the SLM); broadcast together.
    degree
        Maximum total degree ``D``.

    Returns
    -------
    ndarray
        Shape ``broadcast_shape + (n_terms,)``; column ``t`` is ``P_i(û) P_j(v̂)`` for the
        ``t``-th pair of :func:`legendre2d_terms`.

    Examples
    --------
    >>> legendre2d_design(0.5, -1.0, 1)  # P0 P0, P1(û) P0, P0 P1(v̂)
    array([ 1. ,  0.5, -1. ])
    """
    terms = legendre2d_terms(degree)
    u, v = np.broadcast_arrays(
        np.asarray(u_hat, dtype=np.float64), np.asarray(v_hat, dtype=np.float64)
    )
    # legvander promotes 0-d input to 1-d; restore the broadcast shape.
    pu = legendre.legvander(u, degree).reshape((*u.shape, degree + 1))
    pv = legendre.legvander(v, degree).reshape((*v.shape, degree + 1))
    i_idx = np.array([i for i, _ in terms])
    j_idx = np.array([j for _, j in terms])
    return pu[..., i_idx] * pv[..., j_idx]


def field_coordinates(
    u: ArrayLike, v: ArrayLike, slm_shape: tuple[int, int]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """SLM pixel ``(u, v)`` -> normalised field coordinates ``(û, v̂)`` in −1..1.

    Parameters
    ----------
    u, v
        SLM column and row (pixel centres at integers); ``u`` and ``v`` keep their own
        shapes.
    slm_shape
        SLM ``(H, W)`` in pixels.

    Returns
    -------
    u_hat, v_hat : ndarray
        ``2u / (W − 1) − 1`` and ``2v / (H − 1) − 1``.

    Examples
    --------
    >>> field_coordinates([0, 639], [0, 399], (400, 640))
    (array([-1.,  1.]), array([-1.,  1.]))
    """
    height, width = slm_shape
    u_hat = 2.0 * np.asarray(u, dtype=np.float64) / (width - 1) - 1.0
    v_hat = 2.0 * np.asarray(v, dtype=np.float64) / (height - 1) - 1.0
    return u_hat, v_hat


def horner(s: ArrayLike, coeffs: NDArray[np.float64]) -> NDArray[np.float64]:
    """The power series ``sum_k coeffs[k] * s**k``, by Horner's rule, in place.

    numpy's ``polyval`` allocates a new array at every step; on the streak geometry of a
    prototype-scale frame (4320 pixels x 137 wavelengths) this is twice as fast.

    Parameters
    ----------
    s
        The variable of the series.
    coeffs
        ``(K, ...)``: the coefficient of power ``k`` on the first axis; ``coeffs[k]``
        broadcasts with ``s``.

    Returns
    -------
    ndarray
        float64 of the broadcast shape of ``s`` and ``coeffs[0]``.

    Examples
    --------
    >>> horner(np.array([2.0]), np.array([1.0, 0.0, 3.0])).tolist()
    [13.0]
    >>> horner(np.array([0.0, 1.0]), np.array([[1.0], [2.0]])).tolist()  # 1 + 2 s per row
    [1.0, 3.0]
    """
    s = np.asarray(s, dtype=np.float64)
    out = np.empty(np.broadcast_shapes(s.shape, coeffs.shape[1:]))
    out[...] = coeffs[-1]
    for c in coeffs[-2::-1]:
        out *= s
        out += c
    return out
