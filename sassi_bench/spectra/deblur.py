"""The within-streak deblur: undo the spill of each bin's light into its neighbours.

Within a streak the blur spills each bin into its neighbours, up to about 3.5 bins at the
red end; that mixing matrix (uniform box blurred by a Gaussian, integrated over each bin's
columns, in closed form: :func:`spill_matrix`) depends only on relative positions, so its
regularised inverse is diagonalised once at a coarse grid of field points
(:class:`SpectralDeblur`) and applied with each pixel's own smoothing weight, which follows
its signal, so dark pixels are smoothed more than bright ones. A few one-pixel guard bins
beyond 400 and 700 nm absorb light from outside the band.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import eigh
from scipy.special import ndtr

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.spectra.geometry import GUARD_BINS, streak_geometry

__all__ = ["MIN_SMOOTHING", "SpectralDeblur", "spill_matrix"]


def _psi(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """Antiderivative of the normal CDF: z Phi(z) + phi(z)."""
    return z * ndtr(z) + np.exp(-0.5 * z * z) / np.sqrt(2.0 * np.pi)


def spill_matrix(x_left, x_right, sigma) -> NDArray[np.float64]:
    """Fraction of bin b' light (uniform over its columns, Gaussian-blurred) in bin b's
    columns: ``A[..., b, b']``.

    Examples
    --------
    >>> a = spill_matrix(np.array([0.0, 1.0]), np.array([1.0, 2.0]), np.array([1e-6, 1e-6]))
    >>> a.round(3).tolist()
    [[1.0, 0.0], [0.0, 1.0]]
    """
    x0, x1 = x_left[..., :, None], x_right[..., :, None]
    s0, s1 = x_left[..., None, :], x_right[..., None, :]
    sg = np.broadcast_to(sigma, x_left.shape)[..., None, :]
    width = s1 - s0
    return (sg / width) * (
        _psi((x1 - s0) / sg) - _psi((x1 - s1) / sg) - _psi((x0 - s0) / sg) + _psi((x0 - s1) / sg)
    )


#: The smallest smoothing weight a pixel gets (the brightest pixels' floor).
MIN_SMOOTHING = 0.25


@dataclass(frozen=True)
class SpectralDeblur:
    """Regularised inverses of the within-streak spill, on a coarse grid of field points.

    The unmixing solves, per pixel, ``min |A x - y|^2 + s^2 |W L x|^2`` with ``A`` the
    spill matrix, ``L`` the second difference along the bins and ``W`` the blur sigma of
    each bin over the largest one: curvature is penalised where the blur mixes bins, while
    where the blur is narrower than a bin the data alone decide. The weight ``s`` follows
    each pixel's signal, ``s = strength * sqrt(full_scale / mean bin signal)``: with
    photon-limited noise (variance proportional to the signal) and a prior whose scale
    follows the spectrum's own level, that is the noise-whitened Tikhonov weight, so dark
    pixels are smoothed more than bright ones. A single weight for all pixels either
    leaves dark pixels noisy or flattens the LED's blue peak in bright ones.

    Every pixel has its own weight, yet no per-pixel solve is needed: at each field point
    ``A^T A + s^2 Q`` (``Q`` the scaled penalty) is diagonalised for all ``s`` at once by
    the generalised eigenvectors ``Z`` of ``(Q, A^T A + s0^2 Q)``, so the solution is
    ``Z diag(1 / (1 + (s^2 - s0^2) lambda)) (A Z)^T y``: two fixed matrix products and a
    per-pixel scaling. Each pixel uses the operators of its nearest field point: they
    change slowly over the field (blending the four nearest bilinearly changed the
    ColorChecker cube by 1.4e-4 RMS, relative, at four times the cost).

    Build once per bundle with :meth:`from_bundle`; :meth:`apply` unmixes spectra.
    """

    grid_u: NDArray[np.float64]
    grid_v: NDArray[np.float64]
    project: NDArray[np.float64]  # (len(grid_v), len(grid_u), B', B'): (A Z)^T
    eigenvalues: NDArray[np.float64]  # (len(grid_v), len(grid_u), B')
    expand: NDArray[np.float64]  # (len(grid_v), len(grid_u), B', B'): Z
    strength: float
    full_scale: float

    @classmethod
    def from_bundle(
        cls,
        bundle: CalibrationBundle,
        *,
        strength: float = 1.5,
        full_scale: float = 65535.0,
        points: tuple[int, int] = (9, 6),
        guard: int = GUARD_BINS,
    ) -> SpectralDeblur:
        """Diagonalise the regularised normal equations at a grid of field points.

        Parameters
        ----------
        bundle
            The calibration bundle (streak geometry and blur).
        strength
            Smoothing weight of a pixel whose mean bin signal is ``full_scale``.
        full_scale
            The camera's full-scale reading (ADU), the reference signal level.
        points
            Field points (along u, along v) at which the operators are computed.
        guard
            Guard bins at each end of the band (see :func:`streak_geometry`).

        Examples
        --------
        >>> deblur = SpectralDeblur.from_bundle(bundle)  # doctest: +SKIP
        """
        h, w = bundle.slm_shape
        gu = np.linspace(0, w - 1, points[0])
        gv = np.linspace(0, h - 1, points[1])
        vv, uu = np.meshgrid(gv, gu, indexing="ij")
        geo = streak_geometry(bundle, vv.ravel(), uu.ravel(), guard)
        a = spill_matrix(geo.x_left, geo.x_right, geo.sigma)  # (P, B', B')
        n = a.shape[-1]
        weight = geo.sigma[1:-1] / geo.sigma.max()
        penalty = weight[:, None] * np.diff(np.eye(n), 2, axis=0)
        roughness = penalty.T @ penalty
        project, eigenvalues, expand = [], [], []
        for spill in a:  # a few dozen field points, each a small symmetric eigenproblem
            gram = spill.T @ spill
            q = (np.trace(gram) / n) * roughness
            lam, z = eigh(q, gram + MIN_SMOOTHING**2 * q)
            project.append((spill @ z).T)
            eigenvalues.append(np.clip(lam, 0.0, None))
            expand.append(z)
        grid = (points[1], points[0])
        return cls(
            gu,
            gv,
            np.reshape(project, (*grid, n, n)),
            np.reshape(eigenvalues, (*grid, n)),
            np.reshape(expand, (*grid, n, n)),
            float(strength),
            float(full_scale),
        )

    def smoothing(
        self, values: NDArray[np.float64], guard: int = GUARD_BINS
    ) -> NDArray[np.float64]:
        """Each pixel's smoothing weight from its (N, B') column sums."""
        level = np.clip(values[:, guard : values.shape[1] - guard].mean(axis=1), 1e-12, None)
        return np.maximum(self.strength * np.sqrt(self.full_scale / level), MIN_SMOOTHING)

    @cached_property
    def _single(self) -> tuple[NDArray[np.float32], ...]:
        """The operators in single precision (for :meth:`apply` on float32 values)."""
        return tuple(a.astype(np.float32) for a in (self.project, self.eigenvalues, self.expand))

    def apply(self, values: NDArray[np.floating], rows, cols) -> NDArray[np.floating]:
        """Unmix (N, B') column sums of pixels at SLM (rows, cols), each solved exactly for
        its own smoothing weight with the operators of its nearest field point.

        Computes in the precision of ``values``: float32 halves the cost of the products
        and changes the result by about 5e-7 of the spectrum (float32 cubes keep 6e-8).
        """
        single = values.dtype == np.float32
        dtype = np.float32 if single else np.float64
        project, eigenvalues, expand = (
            self._single if single else (self.project, self.eigenvalues, self.expand)
        )
        extra = (self.smoothing(values) ** 2 - MIN_SMOOTHING**2).astype(dtype)
        fv = np.interp(rows, self.grid_v, np.arange(self.grid_v.size))
        fu = np.interp(cols, self.grid_u, np.arange(self.grid_u.size))
        point = np.rint(fv).astype(np.intp) * self.grid_u.size + np.rint(fu).astype(np.intp)
        # Pixels sorted by field point, so that each point's are one contiguous block.
        order = np.argsort(point, kind="stable")
        point, extra = point[order], extra[order, None]
        ordered = values[order].astype(dtype, copy=False)
        edges = np.unique(np.r_[0, np.flatnonzero(np.diff(point)) + 1, point.size])
        for start, stop in itertools.pairwise(edges):  # one pass per field point
            g = np.unravel_index(point[start], eigenvalues.shape[:2])
            coords = ordered[start:stop] @ project[g].T
            coords /= 1.0 + extra[start:stop] * eigenvalues[g]
            np.matmul(coords, expand[g].T, out=ordered[start:stop])
        out = np.empty(values.shape, dtype)
        out[order] = ordered
        return out
