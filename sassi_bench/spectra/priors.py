"""Smoothness priors of the within-streak deblur: the penalty ``|P x|^2`` on a spectrum.

Both priors penalise curvature along the bins, weighted by each bin's blur over the
widest: where the blur spreads a bin over its neighbours the data cannot tell a rough
spectrum from a smooth one, while where the blur is narrower than a bin the data alone
decide.

* :class:`SmoothnessPrior` penalises the curvature of ``x`` itself on the band and one
  guard bin beyond each end, and puts only a ridge of ``guard_weight`` on the guard bins
  further out: light beyond the band can stop (on the virtual bench it ends at 720 nm)
  without the prior pulling the band's last bins along, as a curvature penalty across
  that cut-off does (``docs/notes/2026-12-01-measured-in-code-comments.md``).
* :class:`RelativeSmoothnessPrior` penalises the curvature of ``x / m``, ``m`` a mean
  spectrum (the scan's own): what every pixel shares (the lamp's and the LED's shape, the
  camera's efficiency, the cut-off beyond the band) costs nothing, only each pixel's
  departure from it, its reflectance, which is smooth. Bins where ``m`` is dark get a
  ridge on ``x`` instead. Given the bins' wavelengths (the deblur passes its forward
  model's) it measures both in nanometres, not in camera pixels: the curvature per nm^2
  (divided differences), weighted by the blur in nm. A reflectance is smooth in
  wavelength, and a prism's pixel spans 2 nm at the blue end but 9-12 nm at the red
  (more on a low-dispersion glass): per pixel, the same reflectance is 20-30 times rougher
  at the red end, so a per-pixel prior smooths the red end far more than its data and
  noise call for. Weighted by the blur in nm (not in pixels, not unweighted), it does not
  smooth the blue end harder either. Measured with ``benchmarks/red_end_bound.py``
  (``docs/notes/2026-11-29-docstring-measurements.md``, and ``docs/notes/2026-11-27-red-end.md``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ProcedureError, step_error

__all__ = ["RelativeSmoothnessPrior", "SmoothnessPrior"]


def _curvature(sigma: NDArray[np.float64]) -> NDArray[np.float64]:
    """(P, B' - 2, B') second differences weighted by the blur of the middle bin."""
    n = sigma.shape[-1]
    second = np.diff(np.eye(n), 2, axis=0)
    weight = sigma[:, 1:-1] / sigma.max(axis=1, keepdims=True)
    return weight[:, :, None] * second[None]


def _curvature_nm(sigma: NDArray[np.float64], wavelengths: NDArray[np.float64]) -> NDArray:
    """(P, B' - 2, B') second divided differences along the bins' wavelengths (per nm^2),
    weighted by the middle bin's blur in nm, scaled so the largest stencil weighs 1.

    Examples
    --------
    >>> rows = _curvature_nm(np.ones((1, 5)), np.array([[0.0, 1.0, 2.0, 4.0, 6.0]]))[0]
    >>> rows[[0, 2]].tolist()  # bins twice as wide (same blur in pixels): half the weight
    [[1.0, -2.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.5, -1.0, 0.5]]
    """
    lam = np.asarray(wavelengths, dtype=np.float64)
    n = lam.shape[-1]
    left, right = np.diff(lam, axis=-1)[:, :-1], np.diff(lam, axis=-1)[:, 1:]
    if not np.all((left > 0) & (right > 0)):
        raise ProcedureError(
            step_error(
                "spectral deblur",
                "the bins' wavelengths do not increase along the streak",
                "load a bundle whose dispersion fit passed its checks (sassi-bench bundle verify)",
            )
        )
    centre = 2.0 / (left + right)
    stencil = np.zeros((*left.shape, n))
    k = np.arange(n - 2)
    stencil[:, k, k] = centre / left
    stencil[:, k, k + 1] = -centre * (1.0 / left + 1.0 / right)
    stencil[:, k, k + 2] = centre / right
    # The blur in nm: the bin's blur in pixels times the nm its pixel spans.
    weight = sigma[:, 1:-1] * (left + right) / 2.0
    weight = weight / np.max(weight * centre**2, axis=1, keepdims=True)
    return weight[:, :, None] * stencil


@dataclass(frozen=True)
class SmoothnessPrior:
    """Curvature on the band and one guard bin per side; a ridge on the guards beyond.

    Examples
    --------
    >>> p = SmoothnessPrior(0.5).penalty(np.ones((1, 6)), guard=2)[0]
    >>> p.shape, p[-2:].tolist()  # curvature centred on bins 1-4, ridges on bins 0 and 5
    ((6, 6), [[0.5, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.5]])
    """

    guard_weight: float = 0.0

    @property
    def label(self) -> str:
        """How a report names it."""
        return "curvature"

    def penalty(
        self,
        sigma: NDArray[np.float64],
        guard: int,
        wavelengths_nm: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """(P, K, B') penalty rows at each field point from its bins' blur ``sigma`` (P, B')
        (in bins: ``wavelengths_nm`` is not used)."""
        curvature = _curvature(np.asarray(sigma, dtype=np.float64))
        p, n = sigma.shape
        # Stencil i is centred on bin i + 1: keep those from the first guard beside the
        # band to the last.
        kept = curvature[:, max(guard - 2, 0) : n - guard]
        outside = np.r_[np.arange(max(guard - 1, 0)), np.arange(n - guard + 1, n)]
        ridge = np.zeros((p, outside.size, n))
        ridge[:, np.arange(outside.size), outside] = self.guard_weight
        return np.concatenate([kept, ridge], axis=1)


@dataclass(frozen=True)
class RelativeSmoothnessPrior:
    """Curvature of ``x / mean_spectrum`` on every bin whose mean reaches ``floor`` of its
    band peak; a ridge (as if the mean were ``floor``) on the darker ones. With the bins'
    wavelengths, per nm^2 and weighted by the blur in nm (see the module's note).

    Examples
    --------
    >>> prior = RelativeSmoothnessPrior(np.array([0.0, 1.0, 2.0, 2.0, 1.0]))
    >>> p = prior.penalty(np.ones((1, 5)), guard=1)[0]
    >>> p.shape  # curvature centred on bins 2 and 3, a ridge on the dark bin 0
    (3, 5)
    """

    mean_spectrum: NDArray[np.float64]
    floor: float = 1e-4

    def __post_init__(self) -> None:
        mean = np.asarray(self.mean_spectrum, dtype=np.float64)
        if mean.ndim != 1 or not np.all(np.isfinite(mean)) or np.max(mean) <= 0:
            raise ProcedureError(
                step_error(
                    "spectral deblur",
                    "the mean spectrum of the relative prior has no positive finite signal",
                    "deblur a scan with light in it (check the exposure and the light)",
                )
            )
        object.__setattr__(self, "mean_spectrum", mean)

    @classmethod
    def of(cls, mean_spectrum: ArrayLike, floor: float = 1e-4) -> RelativeSmoothnessPrior:
        """The prior relative to ``mean_spectrum`` (B', guard bins included)."""
        return cls(np.asarray(mean_spectrum, dtype=np.float64), float(floor))

    @property
    def label(self) -> str:
        """How a report names it."""
        return "curvature relative to the scan's mean spectrum"

    def penalty(
        self,
        sigma: NDArray[np.float64],
        guard: int,
        wavelengths_nm: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """(P, K, B') penalty rows at each field point from its bins' blur ``sigma`` (P, B')
        and, when given, their centre wavelengths (P, B'): the curvature per nm^2 weighted
        by the blur in nm; without them, per bin weighted by the blur in pixels."""
        mean = self.mean_spectrum
        n = mean.size
        relative = mean / np.max(mean[guard : n - guard])
        lit = relative >= self.floor
        sigma = np.asarray(sigma, dtype=np.float64)
        if wavelengths_nm is None:
            curvature = _curvature(sigma)
        else:
            curvature = _curvature_nm(sigma, np.broadcast_to(wavelengths_nm, sigma.shape))
        stencils = lit[:-2] & lit[1:-1] & lit[2:]
        scaled = curvature[:, stencils] / np.where(lit, relative, 1.0)
        dark = np.flatnonzero(~lit)
        ridge = np.zeros((sigma.shape[0], dark.size, n))
        ridge[:, np.arange(dark.size), dark] = 1.0 / self.floor
        return np.concatenate([scaled, ridge], axis=1)
