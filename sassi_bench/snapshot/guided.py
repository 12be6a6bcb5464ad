"""The masked guided filter: the cube from the open pixels' spectra and the guide image.

In every window a band is fitted as ``a I + b`` of the guide intensity over the measured
pixels only (weight 1 at measured pixels, 0 elsewhere; ridge ``eps`` on ``a``), and a
pixel's output averages the fits of the windows that hold it, each weighted by its number
of measured pixels. It averages several measured pixels per window, so it suppresses noise
that rank-1 (one region's few pixels) keeps.

The filter is linear in the bands, so it runs in a rank-6 spectral basis of the measured
spectra (the SASSI authors' projection) and the result stays in that factored form
(:class:`~sassi_bench.snapshot.factored.LowRankCube`): 6 filter passes instead of one per
bin, and no dense cube unless asked for.
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray
from threadpoolctl import ThreadpoolController

from sassi_bench._shared.arrays import check_ndim
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot import _kernels
from sassi_bench.snapshot.factored import LowRankCube, spectral_basis
from sassi_bench.snapshot.reconstruct import _check_samples, _open_pixels, guide_intensity

__all__ = ["GUIDED_RANK", "guided_cube", "guided_factors"]

_BLAS = ThreadpoolController()


def _one_blas_thread():
    return _BLAS.limit(limits=1, user_api="blas")


#: Spectral basis of the guided filter (the SASSI authors' rank).
GUIDED_RANK = 6


def guided_cube(
    guide_slm: ArrayLike,
    pixels: ArrayLike,
    spectra: ArrayLike,
    *,
    radius: int | None = None,
    eps: float = 1e-3,
    rank: int | None = GUIDED_RANK,
) -> NDArray[np.float32]:
    """Masked guided filter as a dense cube (:func:`guided_factors` materialised).

    Parameters
    ----------
    guide_slm, pixels, spectra, radius, eps, rank
        As :func:`guided_factors`.

    Returns
    -------
    ndarray
        (H, W, B) float32.

    Examples
    --------
    >>> guide = np.tile(np.arange(1.0, 9.0), (6, 1))  # a ramp
    >>> pixels = np.array([[1, 1], [4, 6], [2, 3]])
    >>> spectra = 5.0 * guide[pixels[:, 0], pixels[:, 1], None] / 8 + 1.0  # affine in it
    >>> cube = guided_cube(guide, pixels, spectra, radius=8, eps=1e-9)
    >>> bool(np.allclose(cube[..., 0], 5.0 * guide / 8 + 1.0, atol=1e-4))
    True
    """
    return guided_factors(guide_slm, pixels, spectra, radius=radius, eps=eps, rank=rank).dense()


def guided_factors(
    guide_slm: ArrayLike,
    pixels: ArrayLike,
    spectra: ArrayLike,
    *,
    radius: int | None = None,
    eps: float = 1e-3,
    rank: int | None = GUIDED_RANK,
) -> LowRankCube:
    """Masked guided filter (weighted least squares on the guide intensity) in a low-rank
    spectral basis.

    The spectra are projected onto their ``rank`` leading singular vectors
    (:func:`~sassi_bench.snapshot.factored.spectral_basis`; the SASSI authors project onto
    6) and each coefficient is filtered as a band: the filter is linear in the bands, so
    this equals filtering the projected spectra band by band, at ``rank`` instead of ``B``
    filter passes.

    In every ``(2 radius + 1)^2`` box window ``k``, each band ``P`` is fitted over the
    measured pixels only as ``P = a_k I + b_k`` (``I`` the guide intensity divided by its
    maximum), minimising ``sum_j (a_k I_j + b_k - P_j)^2 + n_k eps a_k^2`` (``n_k`` the
    measured pixels in the window). The output at a pixel is
    ``sum_k n_k (a_k I + b_k) / sum_k n_k`` over the windows holding it. Box sums come from
    ``cv2.boxFilter``, four bands a pass; the loop is over bands, never pixels.

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, C) guide image on the SLM grid.
    pixels
        The mask or (N, 2) (row, column) of the measured pixels.
    spectra
        (N, B) measured spectra.
    radius
        Window radius in SLM px; default ``1.5 sqrt(H W / N)`` (about nine measured pixels
        a window).
    eps
        Ridge on the slope, in units of the normalised guide's variance: larger values
        flatten the fit towards the window's mean.
    rank
        Spectral basis size; None filters every band (no projection).

    Returns
    -------
    LowRankCube
        (H, W, K) coefficients and the (K, B) basis.

    Examples
    --------
    >>> guide = np.tile(np.arange(1.0, 9.0), (6, 1))
    >>> pixels = np.array([[1, 1], [4, 6], [2, 3]])
    >>> spectra = np.outer(guide[pixels[:, 0], pixels[:, 1]], [1.0, 2.0, 3.0])  # rank 1
    >>> cube = guided_factors(guide, pixels, spectra, radius=8, rank=1)
    >>> cube.coefficients.shape, cube.basis.shape
    ((6, 8, 1), (1, 3))
    """
    step = "snapshot guided filter"
    check_ndim(guide_slm, (2, 3), step=step, name="the guide", fix="pass (H, W[, C])")
    intensity = guide_intensity(guide_slm)
    rows, cols = _open_pixels(pixels, intensity.shape, step)
    intensity, values = _check_samples(intensity, rows, cols, spectra, step)
    if not (np.isfinite(eps) and eps >= 0):
        raise ProcedureError(step_error(step, f"eps is {eps}", "pass a number >= 0"))
    if rank is not None and not (isinstance(rank, (int, np.integer)) and rank >= 1):
        raise ProcedureError(step_error(step, f"rank is {rank!r}", "pass an integer >= 1 or None"))
    values = np.asarray(values, dtype=np.float64)
    if rank is None:
        basis = np.eye(values.shape[1])
    else:
        with _one_blas_thread():  # tiny products: BLAS's threads only spin against the video's
            basis = spectral_basis(values, rank)
            values = values @ basis.T
    h, w = intensity.shape
    peak = float(intensity.max())
    guide = intensity / peak if peak > 0 else intensity
    if radius is None:
        radius = round(1.5 * float(np.sqrt(h * w / rows.size)))
    size = (2 * int(radius) + 1,) * 2

    def box(image, out=None):
        """The box mean of ``image`` (into ``out`` when given, of its shape)."""
        if out is None:
            return cv2.boxFilter(
                image, cv2.CV_32F, size, normalize=True, borderType=cv2.BORDER_REFLECT
            )
        target = out if out.ndim == 2 or out.shape[2] > 1 else out[..., 0]
        cv2.boxFilter(
            image if image.ndim == 2 or image.shape[2] > 1 else image[..., 0],
            cv2.CV_32F, size, dst=target, normalize=True, borderType=cv2.BORDER_REFLECT,
        )  # fmt: skip
        return out

    weight = np.zeros((h, w), np.float32)
    weight[rows, cols] = 1.0
    g_at = guide[rows, cols]
    n = box(weight)
    present = n > 0.5 / (size[0] * size[1])  # at least one measured pixel in the window
    safe = np.where(present, n, np.float32(1.0))
    sparse = np.zeros((h, w), np.float32)
    sparse[rows, cols] = g_at
    mean_i = box(sparse) / safe
    sparse[rows, cols] = g_at * g_at
    var_i = np.maximum(box(sparse) / safe - mean_i * mean_i, 0.0)
    denominator = var_i + np.float32(eps)
    norm = box(n)
    norm_safe = np.where(norm > 0, norm, np.float32(1.0))
    cube = np.empty((h, w, values.shape[1]), np.float32)
    # Four bands at a time (OpenCV filters up to four channels in one pass) in buffers
    # kept for every chunk (fresh ones cost their page faults each time: at the full SLM a
    # four-band image is 33 MB); the arithmetic between the filters is one compiled pass.
    chunk_width = min(4, values.shape[1])
    buffers = [np.empty(h * w * chunk_width, np.float32) for _ in range(6)]
    sparse = np.zeros(h * w * chunk_width, np.float32)
    for start in range(0, values.shape[1], 4):
        chunk = values[:, start : start + 4].astype(np.float32)
        k = chunk.shape[1]
        shaped = [buffer[: h * w * k].reshape(h, w, k) for buffer in buffers]
        sum_p, sum_pi, a, b, box_a, box_b = shaped
        image = sparse[: h * w * k].reshape(h, w, k)
        image[rows, cols] = chunk
        box(image, sum_p)
        image[rows, cols] = chunk * g_at[:, None]
        box(image, sum_pi)
        image[rows, cols] = 0.0
        _kernels.weighted_lines(sum_p, sum_pi, safe, n, mean_i, denominator, present, a, b)
        _kernels.apply_lines(box(a, box_a), box(b, box_b), guide, norm_safe, cube, start)
    return LowRankCube(cube, basis.astype(np.float32))
