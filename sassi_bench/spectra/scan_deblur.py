"""The deblur stage of a scan's assembly: one regularisation for the session, chosen from it.

The regularisation is chosen once per *session*, from a fixed sample of it: every pixel
of a few of its frames (:func:`sample_frames`, a seeded choice among the session's pinhole
frames, enough for :data:`SAMPLE_PIXELS` pixels), extracted whole whatever region is
assembled (:class:`ChoiceSample`). So a cube of a region of interest is deblurred exactly
as the same region of the whole scan: same mean spectrum, same strength, and each pixel
solved alone. (Chosen from the pixels assembled instead, a region's cube differed from
the whole scan's there by up to 2.4 % of the peak.)

After the spectra pass every measured pixel's unmixed column sums and their noise
variance are known (:mod:`~sassi_bench.spectra.scan`). Then:

1. the session's mean spectrum, the column sums of the sample's good pixels averaged
   per field point and deblurred once at the mean's noise
   (:class:`~sassi_bench.spectra.deblur.MeanDeblur`);
2. the per-pixel prior: curvature relative to that mean
   (:class:`~sassi_bench.spectra.priors.RelativeSmoothnessPrior`), so what all pixels
   share (the light, the camera, the cut-off beyond the band) is not smoothed away;
3. the strength of the per-pixel weights, chosen on :data:`CHOICE_PIXELS` of the sample's
   pixels by the pooled discrepancy principle
   (:meth:`~sassi_bench.spectra.deblur.SpectralDeblur.choose`);
4. every pixel deblurred, block by block on all workers, and the per-band noise of the
   result (its PSNR against the noise alone) estimated on the sample, from each bin's
   own variance and its covariance with its neighbours (the weights of step 3 take the
   mean of the bins' variances).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.deblur import CHOICE_PIXELS, MeanDeblur, MeanSpectrum, SpectralDeblur
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.noise import NEIGHBOUR_REACH
from sassi_bench.spectra.priors import RelativeSmoothnessPrior
from sassi_bench.spectra.regularisation import RegularisationChoice

__all__ = [
    "SAMPLE_PIXELS",
    "ChoiceSample",
    "KeptSums",
    "ScanDeblur",
    "deblur_scan",
    "labelled_mean_spectra",
    "sample_frames",
    "scan_mean_spectrum",
    "stack_bins",
]

#: Pixels (whole frames) of a session that choose its regularisation: their mean gives the
#: mean spectrum (the mean of 16384 pixels has a noise far under the forward model's
#: error) and :data:`~sassi_bench.spectra.deblur.CHOICE_PIXELS` of them the strength.
SAMPLE_PIXELS = 16384


class KeptSums(Protocol):
    """A scan that kept its column sums (:class:`~sassi_bench.spectra.scan.ScanCube`)."""

    column_sums: NDArray[np.float32] | None
    noise_variance: NDArray[np.float32] | None
    origin: tuple[int, int]


#: Pixels deblurred per block.
BLOCK_PIXELS = 32768


@dataclass(frozen=True)
class ScanDeblur:
    """What the deblur stage decided and measured.

    Attributes
    ----------
    choice
        The per-pixel strength and how it was chosen.
    mean_spectrum
        (B',) the scan's deblurred mean light per bin and second, guard bins included.
    band_noise_psnr_db
        (B,) the cube's peak over the RMS noise of its deblurred spectra, per band.
    """

    choice: RegularisationChoice
    mean_spectrum: NDArray[np.float64]
    band_noise_psnr_db: NDArray[np.float64]


def stack_bins(core: NDArray, guards: NDArray, guard: int) -> NDArray:
    """(..., B') column sums from the band's (..., B) and the guards' (..., 2 guard).

    Examples
    --------
    >>> stack_bins(np.array([[5.0, 6.0]]), np.array([[1.0, 9.0]]), 1).tolist()
    [[1.0, 5.0, 6.0, 9.0]]
    """
    return np.concatenate([guards[..., :guard], core, guards[..., guard:]], axis=-1)


def sample_frames(
    steps: Sequence[int], pixels_per_frame: int, size: int = SAMPLE_PIXELS
) -> frozenset[int]:
    """The frames of a session whose every pixel judges its regularisation.

    A fixed, seeded choice among the session's pinhole frames ``steps``, as many as hold
    ``size`` pixels: it depends on the session alone, never on the region assembled.

    Examples
    --------
    >>> sorted(sample_frames(range(1, 501), 512))  # doctest: +ELLIPSIS
    [2, 8, 17, ...]
    >>> len(sample_frames(range(1, 501), 512)), len(sample_frames([1, 2, 3], 512))
    (32, 3)
    """
    steps = np.asarray(sorted(int(i) for i in steps), dtype=np.intp)
    count = min(steps.size, math.ceil(size / max(int(pixels_per_frame), 1)))
    picked = np.random.default_rng(0).choice(steps, count, replace=False)
    return frozenset(int(i) for i in picked)


@dataclass(frozen=True)
class ChoiceSample:
    """The pixels that choose a session's regularisation (every pixel of
    :func:`sample_frames`), unmixed as the scan's own.

    Attributes
    ----------
    values
        (N, B') unmixed column sums (camera units per frame), guard bins included.
    rows, cols
        Their SLM pixels.
    variance
        (N, B') their column sums' noise variance, per bin.
    covariance
        (N, K, B') the covariance of each bin's column sum with the next K bins'
        (:meth:`~sassi_bench.spectra.noise.CountsNoise.neighbour_covariance`).
    exposure
        (N,) their frames' exposure (s).
    """

    values: NDArray[np.float32]
    rows: NDArray[np.intp]
    cols: NDArray[np.intp]
    variance: NDArray[np.float64]
    covariance: NDArray[np.float64]
    exposure: NDArray[np.float64]

    @classmethod
    def of(cls, parts: Sequence[tuple[NDArray, ...]], bins: int) -> ChoiceSample:
        """The sample from per-frame ``(values, rows, cols, variance, covariance, exposure,
        good)``, in the order given (sort them by frame), keeping the good pixels with
        light.

        Examples
        --------
        >>> part = (np.ones((2, 3)), np.array([0, 5]), np.array([7, 7]), np.ones((2, 3)),
        ...         np.zeros((2, 2, 3)), np.full(2, 0.1), np.array([True, False]))
        >>> ChoiceSample.of([part], 3).rows.tolist()
        [0]
        """
        if not parts:
            empty = np.zeros(0)
            return cls(np.zeros((0, bins), np.float32), empty.astype(np.intp),
                       empty.astype(np.intp), np.zeros((0, bins)),
                       np.zeros((0, NEIGHBOUR_REACH, bins)), empty)  # fmt: skip
        values, rows, cols, variance, covariance, exposure, good = (
            np.concatenate(column) for column in zip(*parts, strict=True)
        )
        keep = good & (values.mean(axis=1) > 0)
        return cls(
            values[keep].astype(np.float32, copy=False),
            rows[keep].astype(np.intp),
            cols[keep].astype(np.intp),
            variance[keep].astype(np.float64),
            covariance[keep].astype(np.float64),
            exposure[keep].astype(np.float64),
        )


def deblur_scan(
    work: NDArray[np.float32],
    guards: NDArray[np.float32],
    exposure: NDArray[np.float32],
    sample: ChoiceSample,
    good: NDArray[np.bool_],
    origin: tuple[int, int],
    model: StreakForwardModel,
    full_scale: float,
    run: Callable[[Callable, list, str], list],
) -> ScanDeblur | None:
    """Deblur a scan's work area in place: ``work`` becomes light per bin and second.

    Parameters
    ----------
    work, guards
        (H, W, B) and (H, W, 2 guard) unmixed column sums (camera units, per frame).
    exposure
        (H, W) each pixel's exposure (s); 0 where the pixel was not extracted.
    sample
        The session's pixels that choose the regularisation.
    good
        (H, W) pixels that are scored (quality 0): the cube's peak for the noise PSNR.
    origin
        SLM (row, column) of the work area's first pixel.
    model
        The bundle's streak forward model.
    full_scale
        The camera's full-scale reading (the per-pixel weights' reference level).
    run
        ``run(task, items, label)`` runs ``task`` on every item (threads, progress).

    Returns
    -------
    ScanDeblur or None
        None when no pixel of the sample has light (the work area is then only divided by
        the exposure).
    """
    extracted = exposure > 0
    rows, cols = np.nonzero(extracted)
    guard = model.guard
    if sample.rows.size == 0:
        work[extracted] /= exposure[extracted][:, None]
        return None
    values = sample.values.astype(np.float64)
    seconds, bin_var = sample.exposure, sample.variance
    # The weights are chosen for noise taken as white across bins, at its mean (a
    # per-bin weighting of the data measured no better at the red end: see
    # docs/notes/2026-11-27-red-end.md); the cube's stated noise takes each bin's own.
    var = bin_var.mean(axis=1)
    # The anchor allows for the blur's stated error (the 1 % floor of a result's mean
    # smoothed its red end, and every pixel's prior with it).
    anchor = MeanDeblur(model, model_error="blur")
    mean = anchor(values / seconds[:, None], sample.rows, sample.cols, var / seconds**2)
    # The strength is judged on a seeded subset of the sample (the choice's cost grows
    # with its pixels and candidates).
    picked = np.sort(
        np.random.default_rng(0).choice(values.shape[0], min(CHOICE_PIXELS, values.shape[0]),
                                        replace=False)
    )  # fmt: skip
    values, var, bin_var, seconds = values[picked], var[picked], bin_var[picked], seconds[picked]
    slm_r, slm_c = sample.rows[picked], sample.cols[picked]
    deblur = SpectralDeblur.from_model(
        model, RelativeSmoothnessPrior.of(mean.spectrum), full_scale=full_scale
    ).choose(values, slm_r, slm_c, var)
    noise = deblur.posterior_std(values, slm_r, slm_c, bin_var, sample.covariance[picked])
    noise = noise[:, model.core] / seconds[:, None]
    r0, c0 = origin

    def block(start: int) -> None:
        r, c = rows[start : start + BLOCK_PIXELS], cols[start : start + BLOCK_PIXELS]
        spectra = deblur.apply(stack_bins(work[r, c], guards[r, c], guard), r + r0, c + c0)
        work[r, c] = spectra[:, model.core] / exposure[r, c][:, None]

    run(block, list(range(0, rows.size, BLOCK_PIXELS)), "scan deblur")
    judged = good & extracted  # the peak from each pixel's maximum: no gathered cube
    peak = float(work.max(axis=2)[judged].max()) if judged.any() else float(np.max(mean.band))
    band = 10.0 * np.log10(peak**2 / np.maximum(np.mean(noise**2, axis=0), 1e-300))
    assert deblur.choice is not None
    return ScanDeblur(deblur.choice, mean.spectrum, band)


def scan_mean_spectrum(
    scan: KeptSums, bundle_model: StreakForwardModel, where: NDArray[np.bool_], *, trim: float = 0.1
) -> MeanSpectrum:
    """The deblurred mean of a scan's pixels ``where`` (H, W), from their kept column sums.

    The pixels' column sums (:attr:`~sassi_bench.spectra.scan.ScanCube.column_sums`, light
    per second before the deblur) are averaged per field point, trimmed per bin, and each
    mean is deblurred once at its own noise (:class:`~sassi_bench.spectra.deblur.MeanDeblur`).

    Parameters
    ----------
    scan
        A :class:`~sassi_bench.spectra.scan.ScanCube` assembled with ``keep_raw=True``.
    bundle_model
        The bundle's streak forward model.
    where
        (H, W) the pixels to average.
    trim
        Fraction trimmed at each end per bin (dusty or clipped pixels).

    Returns
    -------
    MeanSpectrum
        Light per bin and second, guard bins included.

    Examples
    --------
    Not run here (it needs measured frames)::

        scan = assemble_scan(session, bundle, keep_raw=True)
        white = scan_mean_spectrum(scan, StreakForwardModel.from_bundle(bundle),
                                   scan.quality == 0)
    """
    if scan.column_sums is None or scan.noise_variance is None:
        raise ProcedureError(
            step_error(
                "mean spectrum",
                "the scan kept no column sums to average before the deblur",
                "assemble the scan with keep_raw=True",
            )
        )
    rows, cols = np.nonzero(where)
    return MeanDeblur(bundle_model)(
        scan.column_sums[rows, cols],
        rows + scan.origin[0],
        cols + scan.origin[1],
        scan.noise_variance[rows, cols],
        trim=trim,
    )


def labelled_mean_spectra(
    scan: KeptSums,
    model: StreakForwardModel,
    good: NDArray[np.bool_],
    labels: NDArray[np.integer],
    count: int,
) -> NDArray[np.float64]:
    """The deblurred mean spectrum of every labelled region (chart patches), (count, B).

    Each region's good pixels are averaged and deblurred once at the mean's noise
    (:func:`scan_mean_spectrum`, untrimmed: a patch interior is uniform); regions with no
    good pixel are NaN.

    Examples
    --------
    Not run here (it needs measured frames)::

        means = labelled_mean_spectra(scan, model, scan.quality == 0, labels, 24)
    """
    out = np.full((count, model.n_bins - 2 * model.guard), np.nan)
    for k in range(count):  # a few dozen regions, each one mean
        where = good & (labels == k)
        if where.any():
            out[k] = scan_mean_spectrum(scan, model, where, trim=0.0).band
    return out
