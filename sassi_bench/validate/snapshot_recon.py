"""Snapshot reconstruction and scores, as the snapshot validation runs them.

Spectra at the open pixels of one frame come from :mod:`sassi_bench.spectra` (background
offset from the pixels outside the streaks, row unmixing, within-streak deblur), in the
units of a scan cube (camera units per second per bin, divided by the bundle's response
when it has one), so a snapshot and a scan compare bin for bin on the SLM grid. Two
reconstructions fill the unsampled pixels from the guide image:

* **rank-1 per region**: a pixel's spectrum is its guide intensity over the summed guide
  intensity of its region's sampled pixels, times their summed spectra;
* **masked guided filter** per band, the weighted least-squares form: in every window the
  band is fitted as ``a I + b`` to the sampled pixels only (box means weighted by the
  mask), the coefficients are averaged over the windows covering a pixel, and applied
  to its guide intensity.

Scores: PSNR against the reference's peak (raw, and after the best affine fit of the
whole cube, as the SASSI authors report), SSIM (mean over bands), mean spectral angle
and per-band PSNR.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.extract import SpectralDeblur, extract_spectra, streak_geometry
from sassi_bench.spectra.offset import estimate_background, streak_footprint

__all__ = [
    "Samples",
    "Scores",
    "guide_intensity",
    "guided_filter",
    "measure_samples",
    "rank1",
    "score",
]


@dataclass(frozen=True)
class Samples:
    """Spectra measured at the open pixels of one snapshot frame.

    Attributes
    ----------
    rows, cols
        (N,) SLM coordinates of the open pixels.
    spectra
        (N, B) float32, scan-cube units (per second per bin; radiance with a response).
    background_rms
        RMS misfit of the single-frame background estimate (camera units).
    """

    rows: NDArray[np.intp]
    cols: NDArray[np.intp]
    spectra: NDArray[np.float32]
    background_rms: float


def measure_samples(
    frame: ArrayLike,
    mask: ArrayLike,
    bundle: CalibrationBundle,
    exposure_s: float,
    deblur: SpectralDeblur | None = None,
) -> Samples:
    """Spectra at the open pixels of ``mask`` from one spectral ``frame``.

    Examples
    --------
    >>> samples = measure_samples(frame, mask, bundle, 0.05)  # doctest: +SKIP
    >>> samples.spectra.shape  # (open pixels, bins)  # doctest: +SKIP
    """
    data = np.asarray(frame, dtype=np.float64)
    rows, cols = np.nonzero(np.asarray(mask, dtype=bool))
    if rows.size == 0:
        raise ProcedureError(
            step_error("snapshot spectra", "the mask has no open pixel", "pass a non-empty mask")
        )
    geometry = streak_geometry(bundle, rows, cols)
    background = estimate_background(data, streak_footprint(geometry, data.shape))
    deblur = deblur or SpectralDeblur.from_bundle(bundle)
    spectra, _ = extract_spectra(data - background.image, geometry, deblur)
    spectra = spectra / float(exposure_s)
    if bundle.response is not None:
        spectra = spectra / np.asarray(bundle.response)[None, :]
    return Samples(rows, cols, spectra.astype(np.float32), background.residual_rms)


def guide_intensity(guide_slm: ArrayLike) -> NDArray[np.float32]:
    """The guide image on the SLM grid as one positive intensity (sum of channels)."""
    image = np.asarray(guide_slm, dtype=np.float32)
    intensity = image.sum(axis=2) if image.ndim == 3 else image
    return np.maximum(intensity, np.float32(1e-6) * max(float(intensity.max()), 1e-6))


def rank1(samples: Samples, labels: ArrayLike, intensity: ArrayLike) -> NDArray[np.float32]:
    """Rank-1 reconstruction per region: (H, W, B).

    ``labels`` (H, W) assigns every SLM pixel a region (0 .. K-1); every region holding
    a sampled pixel gets ``I(p) / sum_s I(s) * sum_s spectrum(s)`` over its samples;
    pixels of regions without a sample stay 0.

    Examples
    --------
    >>> s = Samples(np.array([0]), np.array([1]), np.array([[2.0, 4.0]], np.float32), 0.0)
    >>> rank1(s, np.zeros((1, 3), int), np.array([[1.0, 2.0, 4.0]]))[0].tolist()
    [[1.0, 2.0], [2.0, 4.0], [4.0, 8.0]]
    """
    labels = np.asarray(labels, dtype=np.intp)
    intensity = np.asarray(intensity, dtype=np.float64)
    k = int(labels.max()) + 1
    owner = labels[samples.rows, samples.cols]
    summed_i = np.bincount(owner, weights=intensity[samples.rows, samples.cols], minlength=k)
    nb = samples.spectra.shape[1]
    summed = np.zeros((k, nb))
    np.add.at(summed, owner, samples.spectra.astype(np.float64))
    per_intensity = np.divide(
        summed, summed_i[:, None], out=np.zeros_like(summed), where=summed_i[:, None] > 0
    ).astype(np.float32)
    return per_intensity[labels] * intensity.astype(np.float32)[..., None]


def guided_filter(
    samples: Samples,
    intensity: ArrayLike,
    window: tuple[int, int],
    eps: float = 1e-4,
    band_block: int = 16,
) -> NDArray[np.float32]:
    """Masked guided filter per band: (H, W, B).

    Parameters
    ----------
    samples
        The measured spectra.
    intensity
        Guide intensity (H, W) on the SLM grid.
    window
        Box window (rows, columns); it must hold several samples everywhere.
    eps
        Regularisation of the local slope, relative to the squared mean intensity.
    band_block
        Bands filtered together (bounds the memory at the prototype's scale).

    Examples
    --------
    >>> i = np.ones((5, 9)); rows, cols = np.nonzero(np.ones((5, 9))[::2, ::4] > 0)
    >>> s = Samples(rows * 2, cols * 4, np.full((rows.size, 1), 3.0, np.float32), 0.0)
    >>> float(guided_filter(s, i, (3, 5))[2, 4, 0])
    3.0
    """
    guide = np.asarray(intensity, dtype=np.float32)
    guide = guide / np.float32(guide.mean())
    h, w = guide.shape
    ksize = (int(window[1]) | 1, int(window[0]) | 1)  # OpenCV: (width, height), odd

    def box(x: NDArray[np.float32]) -> NDArray[np.float32]:
        out = cv2.boxFilter(x, -1, ksize, normalize=True, borderType=cv2.BORDER_REFLECT)
        return out if out.ndim == x.ndim else out[..., None]

    mask = np.zeros((h, w), np.float32)
    mask[samples.rows, samples.cols] = 1.0
    weight = box(mask)
    tiny = np.float32(1e-12)
    safe = np.maximum(weight, tiny)
    mean_i = box(mask * guide) / safe
    var_i = np.maximum(box(mask * guide * guide) / safe - mean_i * mean_i, 0.0)
    nb = samples.spectra.shape[1]
    out = np.empty((h, w, nb), np.float32)
    for start in range(0, nb, band_block):  # a loop over blocks of bands, not pixels
        stop = min(nb, start + band_block)
        p = np.zeros((h, w, stop - start), np.float32)
        p[samples.rows, samples.cols] = samples.spectra[:, start:stop]
        mean_p = box(p) / safe[..., None]
        mean_ip = box(p * guide[..., None]) / safe[..., None]
        a = (mean_ip - mean_i[..., None] * mean_p) / (var_i[..., None] + np.float32(eps))
        b = mean_p - a * mean_i[..., None]
        has = (weight > tiny)[..., None]
        a, b = np.where(has, a, 0.0), np.where(has, b, 0.0)
        norm = box(has[..., 0].astype(np.float32))[..., None]
        a = box(a) / np.maximum(norm, tiny)
        b = box(b) / np.maximum(norm, tiny)
        out[..., start:stop] = a * guide[..., None] + b
    return out


@dataclass(frozen=True)
class Scores:
    """Scores of a reconstructed cube against a reference cube (same bins, same grid)."""

    psnr_db: float
    psnr_affine_db: float
    ssim: float
    spectral_angle_deg: float
    band_psnr_db: NDArray[np.float64]
    affine: tuple[float, float]

    def to_dict(self) -> dict[str, object]:
        return {
            "psnr_db": self.psnr_db,
            "psnr_affine_db": self.psnr_affine_db,
            "ssim": self.ssim,
            "spectral_angle_deg": self.spectral_angle_deg,
            "band_psnr_db": self.band_psnr_db.tolist(),
            "affine": list(self.affine),
        }


def _psnr(mse: float | NDArray, peak: float) -> float | NDArray:
    return 10.0 * np.log10(peak**2 / np.maximum(mse, 1e-30))


def score(estimate: ArrayLike, reference: ArrayLike, valid: ArrayLike | None = None) -> Scores:
    """PSNR (raw and affine-fitted), SSIM, mean spectral angle and per-band PSNR.

    The peak is the reference's maximum over the valid pixels; the affine fit is one
    gain and offset for the whole cube (least squares). SSIM is scikit-image's, averaged
    over bands, with the reference's range.

    Examples
    --------
    >>> ref = np.random.default_rng(0).random((16, 16, 3))
    >>> s = score(2 * ref + 1, ref)
    >>> s.psnr_affine_db > 100, round(s.spectral_angle_deg, 3) > 0
    (True, True)
    """
    from skimage.metrics import structural_similarity

    est = np.asarray(estimate, dtype=np.float32)
    ref = np.asarray(reference, dtype=np.float32)
    if est.shape != ref.shape:
        raise ProcedureError(
            step_error(
                "snapshot scores",
                f"the reconstruction has shape {est.shape}, the reference {ref.shape}",
                "compare cubes on the same SLM grid and bins",
            )
        )
    good = np.ones(ref.shape[:2], bool) if valid is None else np.asarray(valid, bool)
    e, r = est[good].astype(np.float64), ref[good].astype(np.float64)
    peak = float(r.max())
    mse = float(np.mean((e - r) ** 2))
    design = np.column_stack([e.ravel(), np.ones(e.size)])
    (gain, offset), *_ = np.linalg.lstsq(design, r.ravel(), rcond=None)
    mse_affine = float(np.mean((gain * e + offset - r) ** 2))
    band_mse = np.mean((e - r) ** 2, axis=0)
    dot = np.sum(e * r, axis=1)
    norms = np.linalg.norm(e, axis=1) * np.linalg.norm(r, axis=1)
    angle = np.degrees(np.arccos(np.clip(dot / np.maximum(norms, 1e-30), -1.0, 1.0)))
    ssim = structural_similarity(
        np.where(good[..., None], ref, 0), np.where(good[..., None], est, 0),
        data_range=peak - float(min(r.min(), 0.0)), channel_axis=-1,
    )  # fmt: skip
    return Scores(
        float(_psnr(mse, peak)),
        float(_psnr(mse_affine, peak)),
        float(ssim),
        float(angle.mean()),
        np.asarray(_psnr(band_mse, peak), dtype=np.float64),
        (float(gain), float(offset)),
    )
