"""Smooth interpolants of a traced grid: tensor-product cubic splines over (u, v, lambda).

Each quantity is interpolated by a not-a-knot cubic spline along every axis of the grid
(SLM column, SLM row, wavelength), its tensor coefficients solved once, axis by axis. On
the shipped designs a 17 x 11 field grid at 10 nm steps reproduces held-out traced
positions and spot widths far under a calibration's error
(``docs/notes/2026-11-29-optical_design.md``).

Evaluation goes through the B-spline design matrices: the field part (4 x 4 non-zero
weights per point) and the wavelength part are separate. For a (points x wavelengths)
block the coefficients are first contracted with the wavelengths' basis, once per set
of wavelengths and kept (a renderer asks for the same spectral samples frame after
frame), and then each point costs the sum of 16 weighted rows of them.
Outside the grid's nodes a quantity continues linearly (with its mean slope over the
field), so maps stay monotone where an inverse search strays off the field.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Mapping

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import BSpline, make_interp_spline

from sassi_bench.optics.design._field_sum import weighted_rows

__all__ = ["GridSpline"]

# Sets of wavelengths whose contracted coefficients a spline keeps (a frame's samples, the
# dense renderer's median grid, ...; about 1.5 MB each on the shipped designs).
_CONTRACTED_KEPT = 8


def _basis(x: NDArray[np.float64], knots: NDArray[np.float64]) -> NDArray[np.float64]:
    """Dense cubic B-spline design matrix at ``x`` (already inside the knots' base)."""
    return BSpline.design_matrix(x, knots, 3).toarray()


class GridSpline:
    """Cubic interpolants of quantities given on a regular (u, v, lambda) grid.

    Parameters
    ----------
    u, v, wavelengths_nm
        The grid's nodes (increasing).
    values
        Name -> array (u, v, wavelength).

    Examples
    --------
    >>> u, v, lam = np.linspace(0, 10, 6), np.linspace(0, 5, 5), np.linspace(400, 700, 7)
    >>> U, V, L = np.meshgrid(u, v, lam, indexing="ij")
    >>> spline = GridSpline(u, v, lam, {"q": U * V + (L / 100) ** 3})
    >>> float(np.round(spline.at("q", 3.3, 2.1, 512.0), 6)) == round(3.3 * 2.1 + 5.12**3, 6)
    True
    """

    def __init__(
        self,
        u: ArrayLike,
        v: ArrayLike,
        wavelengths_nm: ArrayLike,
        values: Mapping[str, NDArray[np.float64]],
    ) -> None:
        self.nodes = tuple(np.asarray(a, dtype=np.float64) for a in (u, v, wavelengths_nm))
        self.names = tuple(values)
        stacked = np.stack([np.asarray(values[n], dtype=np.float64) for n in self.names], -1)
        if not np.all(np.isfinite(stacked)):
            raise ValueError("GridSpline: the grid holds NaNs (rays that never arrived)")
        coefficients = stacked
        knots = []
        for axis, nodes in enumerate(self.nodes):
            spline = make_interp_spline(nodes, coefficients, k=3, axis=axis)
            coefficients = np.moveaxis(np.asarray(spline.c), 0, axis) if axis else spline.c
            knots.append(np.asarray(spline.t))
        self._knots = tuple(knots)
        nu, nv, nl = (n.size for n in self.nodes)
        # (field basis u*v) x (wavelength basis) x quantity
        self._coefficients = np.asarray(coefficients).reshape(nu * nv, nl, len(self.names))
        # mean slopes over the field, per wavelength node, for the linear continuation
        du = np.gradient(stacked, self.nodes[0], axis=0).mean(axis=(0, 1))
        dv = np.gradient(stacked, self.nodes[1], axis=1).mean(axis=(0, 1))
        self._slopes = (du, dv)  # (wavelength nodes, quantity)
        self._contracted: OrderedDict[tuple[bytes, tuple[int, ...]], NDArray] = OrderedDict()

    def _field(self, u: NDArray, v: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """The points' field basis as its non-zero weights and their columns, (P, 16)
        each (a cubic B-spline has 4 non-zero weights per point on each axis), and the
        points' distances beyond the nodes."""
        uc = np.clip(u, self.nodes[0][0], self.nodes[0][-1])
        vc = np.clip(v, self.nodes[1][0], self.nodes[1][-1])
        bu = BSpline.design_matrix(uc, self._knots[0], 3)
        bv = BSpline.design_matrix(vc, self._knots[1], 3)
        nv = bv.shape[1]
        weights = bu.data.reshape(-1, 4, 1) * bv.data.reshape(-1, 1, 4)
        columns = bu.indices.reshape(-1, 4, 1) * nv + bv.indices.reshape(-1, 1, 4)
        return weights.reshape(-1, 16), columns.reshape(-1, 16), u - uc, v - vc

    @staticmethod
    def _combine(weights: NDArray, columns: NDArray, coefficients: NDArray) -> NDArray:
        """Each point's 16 weighted coefficient rows, summed: (P, C)."""
        out = np.zeros((weights.shape[0], coefficients.shape[1]))
        weighted_rows(weights, columns, np.ascontiguousarray(coefficients), out)
        return out

    def _wavelength(self, lam: NDArray) -> NDArray:
        nodes = self.nodes[2]
        return _basis(np.clip(lam, nodes[0], nodes[-1]), self._knots[2])

    def _select(self, names: tuple[str, ...]) -> list[int]:
        return [self.names.index(n) for n in names]

    def _by_wavelength(self, lam: NDArray, q: list[int]) -> NDArray:
        """The coefficients contracted with the wavelengths' basis: (field basis, K * q),
        computed once per (wavelengths, quantities) and kept."""
        key = (lam.tobytes(), tuple(q))
        found = self._contracted.get(key)
        if found is not None:
            self._contracted.move_to_end(key)
            return found
        bl = self._wavelength(lam)  # (K, nodes)
        coef = np.einsum("fnq,kn->fkq", self._coefficients[:, :, q], bl, optimize=True)
        coef = np.ascontiguousarray(coef.reshape(coef.shape[0], -1))
        coef.setflags(write=False)
        self._contracted[key] = coef
        if len(self._contracted) > _CONTRACTED_KEPT:
            self._contracted.popitem(last=False)
        return coef

    def grid(
        self, names: tuple[str, ...], u: ArrayLike, v: ArrayLike, wavelengths_nm: ArrayLike
    ) -> NDArray[np.float64]:
        """Quantities at points (u[i], v[i]) and every wavelength: (points, wavelengths, names)."""
        u = np.asarray(u, dtype=np.float64).ravel()
        v = np.asarray(v, dtype=np.float64).ravel()
        lam = np.asarray(wavelengths_nm, dtype=np.float64).ravel()
        q = self._select(names)
        weights, columns, eu, ev = self._field(u, v)
        out = self._combine(weights, columns, self._by_wavelength(lam, q))
        out = out.reshape(u.size, lam.size, len(q))
        if np.any(eu) or np.any(ev):
            bl = self._wavelength(lam)  # (K, nodes)
            su, sv = (bl @ s[:, q] for s in self._slopes)  # (K, q)
            out += eu[:, None, None] * su[None] + ev[:, None, None] * sv[None]
        return out

    def points(
        self, names: tuple[str, ...], u: ArrayLike, v: ArrayLike, wavelengths_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], ...]:
        """Quantities at (u, v, wavelength) broadcast together: one array per name."""
        u, v, lam = np.broadcast_arrays(
            *(np.asarray(a, dtype=np.float64) for a in (u, v, wavelengths_nm))
        )
        shape = u.shape
        u, v, lam = u.ravel(), v.ravel(), lam.ravel()
        q = self._select(names)
        out = np.empty((u.size, len(q)))
        unique, where = np.unique(lam, return_inverse=True)
        bl = self._wavelength(unique)
        weights, columns, eu, ev = self._field(u, v)
        continued = np.any(eu) or np.any(ev)
        for k in range(unique.size):  # one field product per distinct wavelength
            idx = np.flatnonzero(where == k)
            coef = np.einsum("fnq,n->fq", self._coefficients[:, :, q], bl[k])
            out[idx] = self._combine(weights[idx], columns[idx], coef)
            if continued:
                su, sv = (bl[k] @ s[:, q] for s in self._slopes)
                out[idx] += eu[idx, None] * su[None] + ev[idx, None] * sv[None]
        return tuple(out[:, i].reshape(shape) for i in range(len(q)))

    def at(self, name: str, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike) -> NDArray:
        """One quantity at (u, v, wavelength), broadcast."""
        return self.points((name,), u, v, wavelength_nm)[0]
