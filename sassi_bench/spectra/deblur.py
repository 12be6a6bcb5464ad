"""The within-streak deblur: undo the spill of each bin's light into its neighbours.

Within a streak the blur spills each bin into its neighbours, up to about 3.5 bins at the
red end. The spill is an explicit forward model of each streak
(:class:`~sassi_bench.spectra.forward.StreakForwardModel`: every bin's columns and the
blur at its own wavelength, guard bins included), and its regularised inverse
``min |A x - a|^2 + alpha |P x|^2`` (``P`` a smoothness prior,
:mod:`~sassi_bench.spectra.priors`) is diagonalised once per field point: with the
generalised eigenvectors ``Z`` of ``(Q, A^T A + a0 Q)`` the solution for any ``alpha`` is
``Z diag(1 / (1 + (alpha - a0) lambda)) (A Z)^T a``, two fixed matrix products and a
per-pixel scaling, so every pixel gets its own weight at no extra cost.

Two estimators share that machinery:

* :class:`SpectralDeblur`, per pixel (cubes, snapshots). Each pixel's weight follows its
  photon noise, ``alpha = strength^2 * full_scale / level`` (dark pixels are smoothed
  more than bright ones), and the strength is chosen per scan from the data's noise
  (:meth:`SpectralDeblur.choose`, REML pooled over the scan's pixels;
  :mod:`~sassi_bench.spectra.regularisation`).
* :class:`MeanDeblur`, for mean spectra (the white diffuser's, a chart patch's, a scan's
  mean): the raw column sums are averaged first, per field point, and each mean is
  deblurred once at the noise of the mean, which is its pixels' over their count. Noise
  averages out of a mean, bias does not: a mean wants the weak regularisation its own
  noise allows, not the one each pixel needs.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.linalg import eigh
from threadpoolctl import threadpool_limits

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.priors import SmoothnessPrior
from sassi_bench.spectra.regularisation import RegularisationChoice, rule_scores

__all__ = [
    "DEFAULT_STRENGTH",
    "GUARD_WEIGHT",
    "MIN_SMOOTHING",
    "MODEL_ERROR_METHODS",
    "PIXEL_GUARD_WEIGHT",
    "MeanDeblur",
    "MeanSpectrum",
    "SpectralDeblur",
]

#: The smallest smoothing strength a pixel gets (the brightest pixels' floor).
MIN_SMOOTHING = 0.25

#: The per-pixel strength used when none is chosen from the data.
DEFAULT_STRENGTH = 2.5

#: Strengths the per-pixel choice tries (log-spaced).
STRENGTHS = tuple(float(s) for s in np.round(np.geomspace(0.25, 16.0, 19), 4))

#: The ridge on the guard bins beyond the first past each end of the band. The outermost
#: guards are barely observed (most of their light falls beyond the measured columns), so
#: without a ridge they take any value (tails of +-0.8 of the spectrum's peak on the sim
#: rig's ColorChecker); a likelihood choice of the ridge keeps making it weaker, as it buys
#: the fit of the forward model's own error at the band's end. 0.05 lets the light past
#: the band end where it ends (720 nm on the virtual bench) and keeps the response within
#: 3 % on the N-BK7 and SF10 rigs; 0.02-0.1 differ by under 1.5 %.
GUARD_WEIGHT = 0.05

#: The ridge on the outer guard bins of :meth:`SpectralDeblur.from_bundle`'s default prior,
#: the snapshots' per-pixel deblur. Under a dense mask a streak's guard columns are shared
#: with its neighbours' streaks (the column fit leaves their errors there), so the guards
#: are nuisance parameters: a weak ridge lets them take that light instead of the band's
#: end bins; chosen on the sim rig's adaptive snapshots with
#: `benchmarks/snapshot_accuracy.py` (``docs/notes/2026-11-29-docstring-measurements.md``).
#: Isolated streaks, a scan's, want the stronger ridge: there the guards hold the band
#: end's own tail.
PIXEL_GUARD_WEIGHT = 0.003

#: Weights a mean's deblur tries, and the weight its operators are built at.
MEAN_WEIGHTS = tuple(float(a) for a in np.geomspace(1e-6, 1e2, 33))
_MEAN_SHIFT = MEAN_WEIGHTS[0]

#: The forward model's relative accuracy, added to a mean's noise when its weight is
#: judged (:class:`MeanDeblur`'s ``model_error="floor"``, the default, and the fallback
#: for a bundle whose blur states no error of its own): about what a blur curve
#: extrapolated to the guard bins misses of the signal at the band's end
#: (``docs/notes/2026-12-01-measured-in-code-comments.md``).
MODEL_ERROR = 0.01

#: Passes of a mean's weight choice when it allows for the blur's stated error
#: (``model_error="blur"``): the forward model's error is then the spill's change under
#: that error (the forward model's ``spill_error``) applied to the spectrum solved at the
#: last pass's weight, the first at the noise alone; a third pass changed nothing. It
#: serves the scan's anchor; as the response's white it let the first bins ring (an error
#: of the model there that is not the blur's, which the floor covers), so the response and
#: the patches keep the floor. Measured with `benchmarks/accuracy_table.py`
#: (``docs/notes/2026-11-29-docstring-measurements.md``).
MODEL_ERROR_PASSES = 2


#: Pixels at most that judge a scan's strength (spread over the scan).
CHOICE_PIXELS = 4096


class Prior(Protocol):
    """A smoothness prior (:mod:`~sassi_bench.spectra.priors`)."""

    @property
    def label(self) -> str: ...

    def penalty(
        self,
        sigma: NDArray[np.float64],
        guard: int,
        wavelengths_nm: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]: ...


#: Pixels whose solution operators :meth:`_Operators.noise_std` forms at once (B'^2 values
#: each: about 25 MB at 80 bins).
_NOISE_BLOCK = 512


@dataclass(frozen=True)
class _Operators:
    """The generalised eigen decomposition of a prior against the spill, per field point."""

    project: NDArray[np.float64]  # (P, B', B'): (A Z)^T
    eigenvalues: NDArray[np.float64]  # (P, B')
    expand: NDArray[np.float64]  # (P, B', B'): Z
    gains: NDArray[np.float64]  # (P, B'): |A z_i|^2
    shift: float

    @classmethod
    def build(cls, model: StreakForwardModel, prior: Prior, shift: float) -> _Operators:
        penalty = prior.penalty(model.sigma_px, model.guard, model.wavelengths_nm)
        n = model.n_bins
        out: dict[str, list] = {"project": [], "eigenvalues": [], "expand": [], "gains": []}
        # One BLAS thread: the matrices are small, and BLAS's spinning threads contend with
        # any other load (``docs/notes/2026-12-01-measured-in-code-comments.md``).
        with threadpool_limits(limits=1, user_api="blas"):
            for spill, rows in zip(model.spill, penalty, strict=True):  # a few dozen points
                gram = spill.T @ spill
                q = (np.trace(gram) / n) * (rows.T @ rows)
                lam, z = eigh(q, gram + shift * q)
                projected = spill @ z
                out["project"].append(projected.T)
                out["eigenvalues"].append(np.clip(lam, 0.0, None))
                out["expand"].append(z)
                out["gains"].append(np.sum(projected**2, axis=0))
        return cls(*(np.asarray(out[k]) for k in out), float(shift))

    def filters(self, point: NDArray[np.intp], weights: NDArray[np.float64]) -> NDArray:
        """(N, B') ``1 / (1 + (alpha - a0) lambda)`` of spectra at field points ``point``."""
        return 1.0 / (1.0 + (weights[:, None] - self.shift) * self.eigenvalues[point])

    def solve(self, means: NDArray, point: NDArray[np.intp], weights: NDArray) -> NDArray:
        """Deblurred spectra (N, B') of a few spectra at field points ``point``."""
        coords = np.einsum("nij,nj->ni", self.project[point], means)
        return np.einsum("nij,nj->ni", self.expand[point], coords * self.filters(point, weights))

    def noise_std(
        self,
        point: NDArray[np.intp],
        weights: NDArray,
        variance: NDArray,
        covariance: NDArray | None = None,
    ) -> NDArray:
        """(N, B') standard deviation of the solution from noise of ``variance``: (N,) white
        across bins, or (N, B') each bin's own, with ``covariance`` (N, K, B') that of
        each bin with the next K (:meth:`.CountsNoise.neighbour_covariance`).

        White noise takes the decomposition's orthogonality (``A z_i`` are orthogonal, so
        the solution's variance is ``sum_i z_bi^2 f_i^2 |A z_i|^2 v``); other noise needs
        each pixel's whole solution operator ``M = Z diag(f) (A Z)^T``, formed
        :data:`_NOISE_BLOCK` pixels at a time: ``diag(M C M^T)`` for the banded ``C``.
        """
        variance = np.asarray(variance, dtype=np.float64)
        filt = self.filters(point, weights)
        if variance.ndim == 1 and covariance is None:
            spread = np.einsum("nbi,ni->nb", self.expand[point] ** 2, filt**2 * self.gains[point])
            return np.sqrt(variance[:, None] * spread)
        diagonal = np.broadcast_to(variance.reshape(point.size, -1), (point.size, filt.shape[1]))
        out = np.empty(filt.shape)
        for start in range(0, point.size, _NOISE_BLOCK):
            block = slice(start, start + _NOISE_BLOCK)
            points = point[block]
            operator = (self.expand[points] * filt[block, None, :]) @ self.project[points]
            out[block] = np.einsum("nbj,nj->nb", operator**2, diagonal[block])
            for k in range(1, 0 if covariance is None else covariance.shape[1] + 1):
                pairs = operator[:, :, :-k] * operator[:, :, k:]
                out[block] += 2.0 * np.einsum("nbj,nj->nb", pairs, covariance[block, k - 1, :-k])
        return np.sqrt(np.maximum(out, 0.0))

    def noise_covariance(
        self, point: NDArray[np.intp], weights: NDArray, variance: NDArray
    ) -> NDArray:
        """(N, B', B') covariance between bins of the solution from noise of ``variance``
        (N,), white across bins: ``Z diag(f^2 |A z_i|^2) Z^T v``, whose diagonal is
        :meth:`noise_std` squared (the ``A z_i`` are orthogonal)."""
        filt = self.filters(point, weights)
        expand = self.expand[point]
        scaled = expand * (filt**2 * self.gains[point])[:, None, :]
        cov = np.einsum("nbi,nci->nbc", scaled, expand)
        return np.asarray(variance, dtype=np.float64)[:, None, None] * cov


@dataclass(frozen=True)
class SpectralDeblur:
    """Per-pixel deblur: each pixel's weight follows its signal, one strength per scan.

    ``alpha_n = strength^2 * full_scale / level_n`` (``level_n`` the pixel's mean column
    sum over the band): with photon-limited noise (variance proportional to the signal)
    and a prior whose scale follows the spectrum's own level, that is the noise-whitened
    Tikhonov weight. Each pixel uses the operators of its nearest field point.

    Build with :meth:`from_model` (or :meth:`from_bundle`); :meth:`apply` unmixes,
    :meth:`choose` picks the strength from the data's noise, :meth:`posterior_std`
    propagates the noise.
    """

    model: StreakForwardModel
    operators: _Operators
    strength: float
    full_scale: float
    prior: str
    choice: RegularisationChoice | None = None

    @classmethod
    def from_model(
        cls,
        model: StreakForwardModel,
        prior: Prior,
        *,
        strength: float = DEFAULT_STRENGTH,
        full_scale: float = 65535.0,
    ) -> SpectralDeblur:
        """Diagonalise the regularised normal equations of ``prior`` at every field point.

        Examples
        --------
        >>> model = StreakForwardModel.from_bundle(bundle)
        >>> deblur = SpectralDeblur.from_model(model, SmoothnessPrior(0.05))
        """
        operators = _Operators.build(model, prior, MIN_SMOOTHING**2)
        return cls(model, operators, float(strength), float(full_scale), prior.label)

    @classmethod
    def from_bundle(
        cls,
        bundle: CalibrationBundle,
        *,
        strength: float = DEFAULT_STRENGTH,
        full_scale: float = 65535.0,
        prior: Prior | None = None,
    ) -> SpectralDeblur:
        """The per-pixel deblur of a bundle's streaks, for snapshots (default prior:
        :class:`SmoothnessPrior` with the :data:`PIXEL_GUARD_WEIGHT` ridge on the guard
        bins beyond the band).

        Examples
        --------
        Not run here (it needs measured frames)::

            deblur = SpectralDeblur.from_bundle(bundle)
        """
        model = StreakForwardModel.from_bundle(bundle)
        return cls.from_model(
            model,
            prior or SmoothnessPrior(PIXEL_GUARD_WEIGHT),
            strength=strength,
            full_scale=full_scale,
        )

    @property
    def guard(self) -> int:
        """Guard bins at each end."""
        return self.model.guard

    def weights(
        self, values: NDArray[np.floating], strength: float | None = None
    ) -> NDArray[np.float64]:
        """Each pixel's weight ``alpha`` from its (N, B') column sums."""
        s = self.strength if strength is None else strength
        core = values[:, self.model.core]
        level = np.clip(core.mean(axis=1, dtype=np.float64), 1e-12, None)
        return np.maximum(s**2 * self.full_scale / level, MIN_SMOOTHING**2)

    @cached_property
    def _single(self) -> tuple[NDArray[np.float32], ...]:
        """The operators in single precision (for :meth:`apply` on float32 values)."""
        ops = self.operators
        return tuple(a.astype(np.float32) for a in (ops.project, ops.eigenvalues, ops.expand))

    def apply(self, values: NDArray[np.floating], rows, cols) -> NDArray[np.floating]:
        """Unmix (N, B') column sums of pixels at SLM (rows, cols), each solved exactly for
        its own weight with the operators of its nearest field point.

        Computes in the precision of ``values``: float32 halves the cost of the products
        and changes the band's bins by under 1e-6 of the spectrum (about 2e-7 on the sim
        rig; the outer guard bins, under a weak ridge, by up to about 1e-6).
        """
        single = values.dtype == np.float32
        dtype = np.float32 if single else np.float64
        ops = self.operators
        project, eigenvalues, expand = (
            self._single if single else (ops.project, ops.eigenvalues, ops.expand)
        )
        extra = (self.weights(values) - ops.shift).astype(dtype)
        point = self.model.point(rows, cols)
        # Pixels sorted by field point, so that each point's are one contiguous block.
        order = np.argsort(point, kind="stable")
        point, extra = point[order], extra[order, None]
        ordered = values[order].astype(dtype, copy=False)
        edges = np.unique(np.r_[0, np.flatnonzero(np.diff(point)) + 1, point.size])
        for start, stop in itertools.pairwise(edges):  # one pass per field point
            g = point[start]
            coords = ordered[start:stop] @ project[g].T
            coords /= 1.0 + extra[start:stop] * eigenvalues[g]
            np.matmul(coords, expand[g].T, out=ordered[start:stop])
        out = np.empty(values.shape, dtype)
        out[order] = ordered
        return out

    def posterior_std(
        self,
        values: NDArray[np.floating],
        rows,
        cols,
        variance: ArrayLike,
        covariance: NDArray[np.floating] | None = None,
    ) -> NDArray[np.float64]:
        """(N, B') standard deviation of :meth:`apply`'s spectra from the noise alone.

        ``variance`` is each pixel's column-sum noise variance
        (:class:`~sassi_bench.spectra.noise.CountsNoise`), (N, B') per bin, or (N,) when
        it is taken as the same in every bin; ``covariance`` (N, K, B'), if given, that of
        each bin with its next K (the camera columns neighbouring bins share). A scan's
        noise is both: the row unmixing's gain and the cells' read noise grow toward the
        band's red end, and neighbouring bins' sums correlate by about 0.25; a variance
        averaged over the bins, or per bin without the covariance, misstates the cube's
        noise (measured: ``tests/spectra/test_scan_accuracy.py`` and the note
        ``docs/notes/2026-11-29-docstring-measurements.md``).

        Examples
        --------
        Not run here (it needs measured frames)::

            std = deblur.posterior_std(values, rows, cols, variance)
            std.shape == values.shape
            # True
        """
        values = np.asarray(values, dtype=np.float64)
        point = self.model.point(rows, cols)
        return self.operators.noise_std(
            point, self.weights(values), np.asarray(variance), covariance
        )

    def choose(
        self,
        values: NDArray[np.floating],
        rows,
        cols,
        variance: ArrayLike,
        *,
        rule: str = "discrepancy",
        candidates: tuple[float, ...] = STRENGTHS,
    ) -> SpectralDeblur:
        """This deblur with the strength that ``rule`` prefers for these pixels (REML, GCV:
        the best candidate; the discrepancy principle: its root, interpolated between the
        candidates that bracket it).

        Parameters
        ----------
        values
            (N, B') column sums of a sample of the scan's pixels (a few thousand).
        rows, cols
            Their SLM pixels.
        variance
            (N,) the noise variance of each pixel's column sums (mean over bins).
        rule
            ``"reml"``, ``"gcv"`` or ``"discrepancy"``
            (:mod:`~sassi_bench.spectra.regularisation`).
        candidates
            Strengths to try.

        Returns
        -------
        SpectralDeblur
            With ``strength`` and ``choice`` set.
        """
        values = np.asarray(values, dtype=np.float64)
        variance = np.asarray(variance, dtype=np.float64)
        if values.shape[0] == 0:
            raise ProcedureError(
                step_error(
                    "spectral deblur",
                    "no measured pixels to choose the regularisation from",
                    "check the scan's quality mask (saturated or off-camera streaks)",
                )
            )
        ops = self.operators
        point = self.model.point(rows, cols)
        coords = np.einsum("nij,nj->ni", ops.project[point], values)
        terms = [
            rule_scores(
                rule, coords, ops.gains[point], ops.eigenvalues[point],
                self.weights(values, s), variance, ops.shift,
            )
            for s in candidates
        ]  # fmt: skip
        score, residual, dof = (np.asarray(t) for t in zip(*terms, strict=True))
        pooled = RegularisationChoice.pooled(
            rule, score, residual, dof, variance, self.model.n_bins
        )
        best = int(np.argmin(pooled))
        strength = float(candidates[best])
        if rule == "discrepancy":
            expected = self.model.n_bins * np.sum(variance)
            strength = _discrepancy_root(candidates, residual.sum(axis=1) - expected)
        choice = RegularisationChoice(
            rule, "smoothness", strength, tuple(candidates),
            tuple(float(v) for v in pooled), int(values.shape[0]), prior=self.prior,
        )  # fmt: skip
        return replace(self, strength=strength, choice=choice)


def _discrepancy_root(candidates, discrepancy: NDArray[np.float64]) -> float:
    """The strength at which the pooled residual matches the noise, between candidates.

    ``discrepancy`` (K,) is the pooled ``residual - expected`` at each candidate strength;
    it grows with the strength, so it changes sign once. The root is interpolated in log
    strength between the two candidates that bracket it: on a grid a factor 1.26 apart
    two neighbours can score alike, and another sample of pixels then picks the other
    (``docs/notes/2026-12-01-measured-in-code-comments.md``). Without a sign change, the
    candidate nearest to zero.

    Examples
    --------
    >>> round(_discrepancy_root((1.0, 2.0, 4.0), np.array([-3.0, -1.0, 3.0])), 4)
    2.3784
    """
    d = np.asarray(discrepancy, dtype=np.float64)
    crossing = np.flatnonzero((d[:-1] <= 0) & (d[1:] > 0))
    if crossing.size == 0:
        return float(candidates[int(np.argmin(np.abs(d)))])
    k = int(crossing[0])
    t = -d[k] / (d[k + 1] - d[k])
    low, high = np.log(candidates[k]), np.log(candidates[k + 1])
    return float(np.round(np.exp(low + t * (high - low)), 4))


@dataclass(frozen=True)
class MeanSpectrum:
    """A deblurred mean spectrum, guard bins included.

    Attributes
    ----------
    spectrum, std
        (B',) the mean light per bin and its standard deviation from the noise alone.
    count
        Pixels averaged.
    choice
        How its regularisation was chosen.
    guard
        Guard bins at each end.
    covariance
        (B', B') the covariance between bins from the noise alone (the deblur is linear
        in the data, so the pixels' noise passes through the same operator; its
        diagonal is ``std**2``); None when only the standard deviation is known.
    """

    spectrum: NDArray[np.float64]
    std: NDArray[np.float64]
    count: int
    choice: RegularisationChoice
    guard: int
    covariance: NDArray[np.float64] | None = None

    @property
    def band(self) -> NDArray[np.float64]:
        """The spectrum at the bundle's bins, (B,)."""
        return self.spectrum[self.guard : self.spectrum.size - self.guard]

    @property
    def band_covariance(self) -> NDArray[np.float64]:
        """The covariance between the bundle's bins, (B, B); ``diag(std**2)`` when no
        covariance is stated.

        Examples
        --------
        >>> mean = MeanSpectrum(np.ones(4), np.array([9.0, 0.1, 0.2, 9.0]), 50, None, 1)
        >>> mean.band_covariance.round(2).tolist()
        [[0.01, 0.0], [0.0, 0.04]]
        """
        band = slice(self.guard, self.spectrum.size - self.guard)
        if self.covariance is None:
            return np.diag(self.std[band] ** 2)
        return self.covariance[band, band]


def _group_means(values, variance, point, trim):
    """Per field point: mean (trimmed per bin) column sums, mean variance, count."""
    groups, inverse, counts = np.unique(point, return_inverse=True, return_counts=True)
    if trim <= 0:
        sums = np.stack([np.bincount(inverse, weights=col) for col in values.T], axis=1)
        means = sums / counts[:, None]
    else:
        means = np.empty((groups.size, values.shape[1]))
        for g in range(groups.size):  # a few dozen field points
            chunk = values[inverse == g]
            lo, hi = np.percentile(chunk, [100 * trim, 100 * (1 - trim)], axis=0)
            inside = (chunk >= lo) & (chunk <= hi)
            means[g] = np.sum(np.where(inside, chunk, 0.0), 0) / np.maximum(inside.sum(0), 1)
    var = np.bincount(inverse, weights=variance) / counts
    return groups, means, var / counts, counts


def signal_floor_error(choose, noise, means, groups, ops, spill_error) -> NDArray[np.float64]:
    """A mean's weight chosen at its noise plus :data:`MODEL_ERROR` of its signal: the
    forward model's error where no better measure of it is (the response's white, the
    chart's patches; a bundle whose blur states no error).

    ``choose`` picks the weight for a noise variance per mean (``noise``); ``means`` are
    the means' column sums, ``groups`` their field points, ``ops`` the deblur's operators
    and ``spill_error`` the forward model's (unused here)."""
    return choose(noise + MODEL_ERROR**2 * np.mean(means**2, axis=1))


def stated_blur_error(choose, noise, means, groups, ops, spill_error) -> NDArray[np.float64]:
    """A mean's weight chosen at its noise plus its light's change under the blur's stated
    error (the forward model's ``spill_error``) applied to the spectrum solved at the last
    pass's weight, :data:`MODEL_ERROR_PASSES` passes from the noise alone (the scan's
    anchor); the signal floor when the bundle states no error."""
    if spill_error is None:
        return signal_floor_error(choose, noise, means, groups, ops, spill_error)
    alpha = choose(noise)
    for _ in range(MODEL_ERROR_PASSES):
        drift = np.einsum("nij,nj->ni", spill_error[groups], ops.solve(means, groups, alpha))
        alpha = choose(noise + np.mean(drift**2, axis=1))
    return alpha


#: What a mean's weight allows for as the forward model's error (:class:`MeanDeblur`'s
#: ``model_error``), by name.
MODEL_ERROR_METHODS = {"floor": signal_floor_error, "blur": stated_blur_error}


class MeanDeblur:
    """Deblur mean spectra (a white diffuser's, a patch's, a scan's) once, at the mean's
    own noise, with the weight chosen by a rule (REML by default).

    The pixels' raw column sums are averaged per field point (their pixels share one
    spill); each field point's mean is deblurred at its noise, the pixels' variance over
    their count plus the forward model's own error (``model_error``, below: without it
    the rule reads the model's error at the band's end as signal when the mean has tens
    of thousands of pixels), and the means are averaged by pixel count.

    ``model_error`` says which error of the forward model the weight allows for:
    ``"floor"`` (the default), :data:`MODEL_ERROR` of the signal; ``"blur"``, the change
    of the mean's light under the blur's stated error (:data:`MODEL_ERROR_PASSES`; the
    floor when the bundle states none). The scan's anchor takes ``"blur"``; the response's
    white and the chart's patches keep the floor (measured there, below).

    Build once per prior (one decomposition per field point, a few tenths of a second),
    call for every mean.

    Examples
    --------
    Not run here (it needs measured frames)::

        mean = MeanDeblur.from_bundle(bundle)(values, rows, cols, variance)
        mean.band.shape
        # (68,)
    """

    def __init__(
        self, model: StreakForwardModel, prior: Prior | None = None, *, model_error: str = "floor"
    ):
        if model_error not in MODEL_ERROR_METHODS:
            raise ValueError(
                f"model_error must be one of {tuple(MODEL_ERROR_METHODS)}, got {model_error!r}"
            )
        self.model = model
        self.prior = prior or SmoothnessPrior(GUARD_WEIGHT)
        self.model_error = model_error
        self.operators = _Operators.build(model, self.prior, _MEAN_SHIFT)

    @classmethod
    def from_bundle(cls, bundle: CalibrationBundle, prior: Prior | None = None) -> MeanDeblur:
        """The mean deblur of a bundle's streaks."""
        return cls(StreakForwardModel.from_bundle(bundle), prior)

    def __call__(
        self,
        values: NDArray[np.floating],
        rows,
        cols,
        variance: ArrayLike,
        *,
        rule: str = "reml",
        trim: float = 0.0,
    ) -> MeanSpectrum:
        """The deblurred mean of pixels' (N, B') column sums.

        Parameters
        ----------
        values
            (N, B') column sums of the pixels (guard bins included).
        rows, cols
            Their SLM pixels.
        variance
            (N,) noise variance of each pixel's column sums (mean over bins), in the
            units of ``values`` squared.
        rule
            ``"reml"``, ``"gcv"`` or ``"discrepancy"``.
        trim
            Fraction trimmed at each end, per bin and field point, before averaging
            (robust to a few dusty or clipped pixels).
        """
        values = np.asarray(values, dtype=np.float64)
        if values.ndim != 2 or values.shape[0] == 0 or values.shape[1] != self.model.n_bins:
            raise ProcedureError(
                step_error(
                    "mean spectrum",
                    f"got column sums of shape {values.shape}, expected (pixels > 0, "
                    f"{self.model.n_bins})",
                    "pass the measured pixels' column sums with their guard bins",
                )
            )
        point = self.model.point(rows, cols)
        groups, means, noise, counts = _group_means(
            values, np.asarray(variance, dtype=np.float64), point, trim
        )
        ops = self.operators
        coords = np.einsum("nij,nj->ni", ops.project[groups], means)
        weights = np.asarray(MEAN_WEIGHTS)

        def choose(judged: NDArray[np.float64]) -> NDArray[np.float64]:
            scores = np.array(
                [
                    _own_score(rule, coords, ops, groups, np.full(groups.size, a), judged)
                    for a in weights
                ]
            )  # (K, G)
            return weights[np.argmin(scores, axis=0)]

        judge = MODEL_ERROR_METHODS[self.model_error]
        alpha = judge(choose, noise, means, groups, ops, self.model.spill_error)
        solved = ops.solve(means, groups, alpha)
        total = int(counts.sum())
        # the field points' means averaged by pixel count: their covariances by its square
        weight = counts.astype(np.float64) ** 2 / total**2
        covariance = np.einsum("n,nbc->bc", weight, ops.noise_covariance(groups, alpha, noise))
        choice = RegularisationChoice(
            rule, "weight", float(np.median(alpha)), spectra=total,
            guard_weight=getattr(self.prior, "guard_weight", None), prior=self.prior.label,
        )  # fmt: skip
        return MeanSpectrum(
            spectrum=(solved * counts[:, None]).sum(axis=0) / total,
            std=np.sqrt(np.maximum(np.diagonal(covariance), 0.0)),
            count=total,
            choice=choice,
            guard=self.model.guard,
            covariance=covariance,
        )


def _own_score(rule, coords, ops: _Operators, groups, alpha, var) -> NDArray[np.float64]:
    """Each mean's own score at weights ``alpha`` (lower is better)."""
    score, residual, dof = rule_scores(
        rule, coords, ops.gains[groups], ops.eigenvalues[groups], alpha, var, ops.shift
    )
    bins = coords.shape[1]
    if rule == "reml":
        return score
    if rule == "gcv":
        return bins * residual / np.maximum(dof, 1e-9) ** 2
    return np.abs(residual - bins * var)
