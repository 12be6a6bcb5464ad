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
   so its regularised inverse is precomputed on a coarse grid of field points and
   interpolated. A few one-pixel guard bins beyond 400 and 700 nm absorb light from
   outside the band.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
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


@dataclass(frozen=True)
class SpectralDeblur:
    """Regularised inverses of the within-streak spill, on a coarse grid of field points.

    Build once per bundle with :meth:`from_bundle`; :meth:`apply` unmixes spectra.
    """

    grid_u: NDArray[np.float64]
    grid_v: NDArray[np.float64]
    inverse: NDArray[np.float64]  # (len(grid_v), len(grid_u), B', B')

    @classmethod
    def from_bundle(
        cls,
        bundle: CalibrationBundle,
        points: tuple[int, int] = (9, 6),
        smoothing: float = 1.0,
        guard: int = GUARD_BINS,
    ) -> SpectralDeblur:
        """Precompute ``(A^T A + s^2 L^T L)^-1 A^T`` with ``L`` the second difference."""
        h, w = bundle.slm_shape
        gu = np.linspace(0, w - 1, points[0])
        gv = np.linspace(0, h - 1, points[1])
        vv, uu = np.meshgrid(gv, gu, indexing="ij")
        geo = streak_geometry(bundle, vv.ravel(), uu.ravel(), guard)
        a = spill_matrix(geo.x_left, geo.x_right, geo.sigma)  # (P, B', B')
        n = a.shape[-1]
        second = np.diff(np.eye(n), 2, axis=0)
        scale = np.trace(a.transpose(0, 2, 1) @ a, axis1=1, axis2=2)[:, None, None] / n
        normal = a.transpose(0, 2, 1) @ a + smoothing**2 * scale * (second.T @ second)
        inverse = np.linalg.solve(normal, a.transpose(0, 2, 1))
        return cls(gu, gv, inverse.reshape(points[1], points[0], n, n))

    def apply(self, values: NDArray[np.float64], rows, cols) -> NDArray[np.float64]:
        """Unmix (N, B') column sums of pixels at SLM (rows, cols), interpolating bilinearly.

        Each grid point's matrix is applied once to all the pixels of the four cells
        around it (a loop over grid points, not pixels), instead of gathering a matrix
        per pixel.
        """
        fu = np.interp(cols, self.grid_u, np.arange(self.grid_u.size))
        fv = np.interp(rows, self.grid_v, np.arange(self.grid_v.size))
        iu = np.minimum(fu.astype(np.intp), self.grid_u.size - 2)
        iv = np.minimum(fv.astype(np.intp), self.grid_v.size - 2)
        tu, tv = fu - iu, fv - iv
        out = np.zeros_like(values)
        corners = ((0, 0, (1 - tv) * (1 - tu)), (0, 1, (1 - tv) * tu),
                   (1, 0, tv * (1 - tu)), (1, 1, tv * tu))  # fmt: skip
        for dv, du, weight in corners:
            node = (iv + dv) * self.grid_u.size + (iu + du)
            for g in np.unique(node):
                mine = node == g
                matrix = self.inverse[g // self.grid_u.size, g % self.grid_u.size]
                out[mine] += weight[mine, None] * (values[mine] @ matrix.T)
        return out


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
    """Solve banded systems without pivoting, batched over the leading axes.

    ``bands[..., i, p + d]`` holds ``A[i, i + d]`` for ``|d| <= p``; the systems here are
    diagonally dominant (a pixel's own cell holds most of its light).
    """
    a = bands.copy()
    b = rhs.copy()
    n = b.shape[-1]
    for i in range(n):
        pivot = a[..., i, p]
        for r in range(1, p + 1):
            if i + r >= n:
                break
            factor = a[..., i + r, p - r] / pivot
            # Row i + r -= factor * row i, over the band columns i .. i + p.
            a[..., i + r, p - r : 2 * p + 1 - r] -= factor[..., None] * a[..., i, p : 2 * p + 1]
            b[..., i + r] -= factor * b[..., i]
    x = np.zeros_like(b)
    for i in range(n - 1, -1, -1):
        acc = b[..., i].copy()
        for d in range(1, p + 1):
            if i + d < n:
                acc -= a[..., i, p + d] * x[..., i + d]
        x[..., i] = acc / a[..., i, p]
    return x


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
