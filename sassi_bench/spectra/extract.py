"""Spectrum extraction: the spectrum of every open SLM pixel of a frame, at the bundle's bins.

A frame of open pixels is a sum of streaks: pixel ``j``'s light of bin ``b`` is spread
uniformly over the bin's camera columns (``x_left .. x_right`` from the bundle) and
blurred by the bundle's Gaussian ``sigma_b`` in both directions. Extraction inverts that
model in two separable, vectorised steps:

1. **Rows.** For each pixel and bin, the light is summed over the bin's columns
   (fractional end columns) and over the rows nearer to this pixel's bin centre than to
   any other open pixel of the same SLM column (its *cell*; at most +-3 sigma). At the
   standard 5 px vertical pitch the blurred profiles of neighbours overlap, so the cell
   sums of one SLM column are a banded mixture of the true amplitudes; the mixture is
   known from the bundle (Gaussian integrals over the cells) and is solved per column
   and bin with a batched banded solver.
2. **Columns.** Within a streak the blur also spills each bin into its neighbours, up to
   about 3.5 bins at the red end; that mixing matrix (uniform box blurred by a Gaussian,
   integrated over each bin's columns, in closed form) depends only on relative positions,
   so its regularised inverse is precomputed on a coarse grid of field points and a
   ladder of smoothing weights, and interpolated; the weight follows each pixel's
   signal, so dark pixels are smoothed more than bright ones. A few one-pixel guard
   bins beyond 400 and 700 nm absorb light from outside the band.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import solve_banded
from scipy.special import ndtr

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import step_error

__all__ = ["SpectralDeblur", "StreakGeometry", "extract_spectra", "streak_geometry"]

GUARD_BINS = 6


@dataclass(frozen=True)
class StreakGeometry:
    """Where the bins (with guard bins at both ends) of open pixels fall on the camera.

    Attributes
    ----------
    rows, cols
        SLM coordinates of the open pixels, (N,).
    x_left, x_right
        Camera columns bounding each bin, (N, B + 2 * guard).
    y
        Camera row of each bin's centre, (N, B + 2 * guard).
    sigma
        Blur sigma of each bin, (B + 2 * guard,).
    guard
        Guard bins at each end; the bundle's bins are ``guard .. guard + B``.
    """

    rows: NDArray[np.intp]
    cols: NDArray[np.intp]
    x_left: NDArray[np.float64]
    x_right: NDArray[np.float64]
    y: NDArray[np.float64]
    sigma: NDArray[np.float64]
    guard: int = GUARD_BINS

    @property
    def core(self) -> slice:
        """Index of the bundle's own bins along the bin axis."""
        return slice(self.guard, self.sigma.size - self.guard)


def streak_geometry(
    bundle: CalibrationBundle, rows: ArrayLike, cols: ArrayLike, guard: int = GUARD_BINS
) -> StreakGeometry:
    """Bin footprints of open SLM pixels (rows, cols) on the camera, from a bundle."""
    rows = np.asarray(rows, dtype=np.intp).ravel()
    cols = np.asarray(cols, dtype=np.intp).ravel()
    x_edges, _ = bundle.slm_to_camera(cols[:, None], rows[:, None], bundle.bin_edges[None, :])
    _, y = bundle.slm_to_camera(cols[:, None], rows[:, None], bundle.wavelengths[None, :])
    lo = np.minimum(x_edges[:, :-1], x_edges[:, 1:])
    hi = np.maximum(x_edges[:, :-1], x_edges[:, 1:])
    sigma = np.asarray(bundle.blur_width(bundle.wavelengths), dtype=np.float64)
    steps = np.arange(guard, 0, -1, dtype=np.float64)
    left_lo = lo[:, :1] - steps  # one-pixel guard bins below the band ...
    right_lo = hi[:, -1:] + steps[::-1] - 1.0  # ... and above it
    return StreakGeometry(
        rows=rows,
        cols=cols,
        x_left=np.hstack([left_lo, lo, right_lo]),
        x_right=np.hstack([left_lo + 1.0, hi, right_lo + 1.0]),
        y=np.hstack([np.repeat(y[:, :1], guard, 1), y, np.repeat(y[:, -1:], guard, 1)]),
        sigma=np.concatenate([np.full(guard, sigma[0]), sigma, np.full(guard, sigma[-1])]),
        guard=guard,
    )


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


#: Smoothing weights at which the regularised inverses are precomputed (log-spaced);
#: a pixel's weight is interpolated between the two nearest.
SMOOTHING_LADDER = np.geomspace(0.25, 64.0, 13)


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

    Build once per bundle with :meth:`from_bundle`; :meth:`apply` unmixes spectra.
    """

    grid_u: NDArray[np.float64]
    grid_v: NDArray[np.float64]
    coefficients: NDArray[np.float64]  # (len(SMOOTHING_LADDER), len(grid_v), len(grid_u), K)
    basis: NDArray[np.float64]  # (K, B', B')
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
        """Precompute ``(A^T A + s^2 L^T W^2 L)^-1 A^T`` for every ladder weight ``s``.

        Parameters
        ----------
        bundle
            The calibration bundle (streak geometry and blur).
        strength
            Smoothing weight of a pixel whose mean bin signal is ``full_scale``.
        full_scale
            The camera's full-scale reading (ADU), the reference signal level.
        points
            Field points (along u, along v) at which the inverses are computed.
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
        ata = a.transpose(0, 2, 1) @ a
        scale = np.trace(ata, axis1=1, axis2=2)[:, None, None] / n
        s2 = SMOOTHING_LADDER[:, None, None, None] ** 2
        normal = ata[None] + s2 * scale[None] * (penalty.T @ penalty)
        inverse = np.linalg.solve(normal, np.broadcast_to(a.transpose(0, 2, 1), normal.shape))
        # The inverses vary smoothly over the field and the ladder: a few dozen basis
        # matrices reproduce all of them (to 1e-6 of the largest singular value), so a
        # pixel's interpolated inverse is a weighted sum of the basis, applied to all
        # pixels at once in one matrix product instead of a loop over grid points.
        left, singular, right = np.linalg.svd(inverse.reshape(-1, n * n), full_matrices=False)
        rank = int(np.count_nonzero(singular > 1e-6 * singular[0]))
        shape = (SMOOTHING_LADDER.size, points[1], points[0], rank)
        coefficients = (left[:, :rank] * singular[:rank]).reshape(shape)
        basis = right[:rank].reshape(rank, n, n)
        return cls(gu, gv, coefficients, basis, float(strength), float(full_scale))

    def smoothing(
        self, values: NDArray[np.float64], guard: int = GUARD_BINS
    ) -> NDArray[np.float64]:
        """Each pixel's smoothing weight from its (N, B') column sums."""
        level = np.clip(values[:, guard : values.shape[1] - guard].mean(axis=1), 1e-12, None)
        return self.strength * np.sqrt(self.full_scale / level)

    def apply(self, values: NDArray[np.float64], rows, cols) -> NDArray[np.float64]:
        """Unmix (N, B') column sums of pixels at SLM (rows, cols).

        The inverse is interpolated trilinearly: bilinearly over the field and linearly in
        the log of the smoothing weight (through the coefficients of the basis).
        """
        ladder = np.log(SMOOTHING_LADDER)
        position = [
            np.interp(np.log(self.smoothing(values)), ladder, np.arange(ladder.size)),
            np.interp(rows, self.grid_v, np.arange(self.grid_v.size)),
            np.interp(cols, self.grid_u, np.arange(self.grid_u.size)),
        ]
        grid = self.coefficients.shape[:3]
        base = [
            np.minimum(f.astype(np.intp), size - 2) for f, size in zip(position, grid, strict=True)
        ]
        frac = [f - i for f, i in zip(position, base, strict=True)]
        weights = np.zeros((values.shape[0], self.basis.shape[0]))
        for corner in np.ndindex(2, 2, 2):
            share = np.prod(
                [np.where(c, t, 1 - t) for c, t in zip(corner, frac, strict=True)], axis=0
            )
            index = tuple(i + c for i, c in zip(base, corner, strict=True))
            weights += share[:, None] * self.coefficients[index]
        n = values.shape[1]
        mixed = (values @ self.basis.reshape(-1, n).T).reshape(values.shape[0], -1, n)
        return np.einsum("nk,nkj->nj", weights, mixed)


def _cell_sums(image, geo: StreakGeometry):
    """Sum of each (pixel, bin) over its columns and its cell of rows.

    Returns the sums (N, B'), the cell bounds (N, B') as continuous row coordinates, and
    a flag (N, B') for windows that leave the frame.
    """
    h, w = image.shape
    n = geo.y.shape[0]
    order = np.lexsort((geo.y[:, geo.core].mean(axis=1), geo.cols))
    same_up = np.zeros(n, dtype=bool)
    same_up[order[1:]] = geo.cols[order[1:]] == geo.cols[order[:-1]]
    same_down = np.zeros(n, dtype=bool)
    same_down[order[:-1]] = geo.cols[order[:-1]] == geo.cols[order[1:]]
    above = np.empty(n, dtype=np.intp)
    above[order[1:]] = order[:-1]
    above[order[0]] = order[0]
    below = np.empty(n, dtype=np.intp)
    below[order[:-1]] = order[1:]
    below[order[-1]] = order[-1]
    reach = 3.0 * geo.sigma[None, :]
    lo = np.where(same_up[:, None], (geo.y + geo.y[above]) / 2, -np.inf)
    hi = np.where(same_down[:, None], (geo.y + geo.y[below]) / 2, np.inf)
    lo = np.maximum(lo, geo.y - reach)
    hi = np.minimum(hi, geo.y + reach)
    first_row = np.ceil(lo - 0.5).astype(np.intp)  # rows whose centre lies in [lo, hi)
    last_row = np.ceil(hi - 0.5).astype(np.intp) - 1
    first_col = np.floor(geo.x_left + 0.5).astype(np.intp)
    span = int(np.max(np.floor(geo.x_right + 0.5) - first_col)) + 1
    cols = first_col[..., None] + np.arange(span)
    col_weight = np.clip(
        np.minimum(cols + 0.5, geo.x_right[..., None])
        - np.maximum(cols - 0.5, geo.x_left[..., None]),
        0.0,
        1.0,
    )
    off = (first_row < 0) | (last_row >= h)
    off |= (((cols < 0) | (cols >= w)) & (col_weight > 0)).any(axis=-1)
    # Row sums through a cumulative sum down the columns: two look-ups per column
    # instead of one per row of the cell.
    cumulative = np.vstack([np.zeros((1, w)), np.cumsum(image, axis=0)])
    top = np.clip(first_row, 0, h)[..., None]
    bottom = np.clip(last_row + 1, 0, h)[..., None]
    safe_cols = np.clip(cols, 0, w - 1)
    column_sums = cumulative[bottom, safe_cols] - cumulative[top, safe_cols]
    sums = np.einsum("nbc,nbc->nb", column_sums, col_weight)
    # Continuous bounds of the summed rows, for the Gaussian integrals.
    return sums, first_row - 0.5, last_row + 0.5, off, order, same_up


def _solve_banded(bands: NDArray, rhs: NDArray, p: int) -> NDArray:
    """Solve banded systems batched over the leading axes, in one LAPACK call.

    ``bands[..., i, p + d]`` holds ``A[i, i + d]`` for ``|d| <= p`` (zero where ``i + d``
    leaves the system). The systems are laid end to end as one block-diagonal banded
    system, so LAPACK's banded solver does all of them at once instead of a Python loop
    over systems or over rows.
    """
    size = rhs.shape[-1]
    flat = bands.reshape(-1, 2 * p + 1)
    length = flat.shape[0]
    ab = np.zeros((2 * p + 1, length))
    for d in range(-p, p + 1):  # ab[p - d, j + d] = A[j, j + d]
        ab[p - d, max(d, 0) : length + min(d, 0)] = flat[max(-d, 0) : length - max(d, 0), p + d]
    x = solve_banded((p, p), ab, rhs.reshape(-1), check_finite=False)
    return x.reshape(*rhs.shape[:-1], size)


def _unmix_rows(sums, lo, hi, geo: StreakGeometry, order, same_up, p: int = 3):
    """Separate the cell sums of pixels stacked in one SLM column (banded solve)."""
    n, nb = sums.shape
    starts = np.flatnonzero(~same_up[order])  # first pixel of each SLM column in `order`
    stops = np.r_[starts[1:], n]
    size = int((stops - starts).max())
    groups = starts.size
    slot = np.arange(n) - np.repeat(starts, stops - starts)
    index = np.full((groups, size), -1, dtype=np.intp)
    index[np.repeat(np.arange(groups), stops - starts), slot] = order
    present = index >= 0
    safe = np.where(present, index, 0)
    bands = np.zeros((groups, nb, size, 2 * p + 1))
    sigma = geo.sigma[None, :, None]
    y = geo.y[safe].transpose(0, 2, 1)  # (G, B, S)
    lo_j = lo[safe].transpose(0, 2, 1)
    hi_j = hi[safe].transpose(0, 2, 1)
    for d in range(-p, p + 1):
        k = np.arange(size) + d
        ok = (k >= 0) & (k < size)
        kk = np.clip(k, 0, size - 1)
        y_k = y[..., kk]  # centre of pixel j + d, seen from pixel j's cell
        frac = ndtr((hi_j - y_k) / sigma) - ndtr((lo_j - y_k) / sigma)
        valid = (present & present[:, kk] & ok[None, :])[:, None, :]
        bands[..., p + d] = np.where(valid, frac, 0.0)
    # Empty slots: identity rows, so padded systems stay solvable.
    bands[..., p] = np.where(present[:, None, :], bands[..., p], 1.0)
    rhs = np.where(present[:, None, :], sums[safe].transpose(0, 2, 1), 0.0)
    amplitudes = _solve_banded(bands, rhs, p)  # (G, B, S)
    out = np.empty_like(sums)
    out[index[present]] = amplitudes.transpose(0, 2, 1)[present]
    return out


def extract_spectra(
    image: ArrayLike, geometry: StreakGeometry, deblur: SpectralDeblur | None = None
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """Spectra (N, B) of the open pixels of a background-free frame.

    Parameters
    ----------
    image
        Frame with the background offset (and dark level) removed, (H, W).
    geometry
        From :func:`streak_geometry` for the frame's open pixels.
    deblur
        The within-streak unmixing (:meth:`SpectralDeblur.from_bundle`); None keeps each
        bin's raw column sum (spectrally blurred, but no noise amplification).

    Returns
    -------
    spectra : ndarray
        Signal per pixel and bin (camera units), (N, B).
    off_frame : ndarray
        True where part of a bin's window fell off the camera, (N, B).
    """
    image = np.asarray(image, dtype=np.float64)
    if image.ndim != 2:
        raise ValueError(
            step_error(
                "spectrum extraction", f"frame has shape {image.shape}", "pass one 2-D frame"
            )
        )
    if geometry.rows.size == 0:
        nb = geometry.sigma.size - 2 * geometry.guard
        return np.zeros((0, nb)), np.zeros((0, nb), dtype=bool)
    sums, lo, hi, off, order, same_up = _cell_sums(image, geometry)
    amplitudes = _unmix_rows(sums, lo, hi, geometry, order, same_up)
    if deblur is not None:
        amplitudes = deblur.apply(amplitudes, geometry.rows, geometry.cols)
    core = geometry.core
    return amplitudes[:, core], off[:, core]
