"""Choosing the deblur's regularisation from the data's noise, and recording the choice.

The deblur solves ``min |A x - a|^2 + alpha |P x|^2`` per pixel. In the generalised
eigenvectors ``Z`` of the penalty and the normal matrix (``Z^T (A^T A + a0 Q) Z = I``,
``Z^T Q Z = diag(lambda)``, ``Q = P^T P``) every rule that judges ``alpha`` costs a few
operations per bin: with ``c = (A Z)^T a``, ``d = 1 - a0 lambda`` (``|A z_i|^2``) and the
filter ``f = 1 / (1 + (alpha - a0) lambda)``,

* residual ``|a - A x|^2 = sum (c^2 / d) (1 - f d)^2``, and ``trace(H) = sum f d``;
* **REML** (the restricted likelihood of the data under Gaussian noise of the known
  variance ``sigma^2`` and the Gaussian smoothness prior the penalty stands for):
  ``-2 log L = sum_{lambda > 0} log v + c^2 / (d v)``, ``v = sigma^2 (1 + d / (alpha lambda))``;
* **GCV**: ``m |r|^2 / (m - trace H)^2`` (needs no noise level);
* the **discrepancy principle**: the ``alpha`` whose residual matches ``m sigma^2``.

One spectrum has few bins (about 80), too few for GCV or the discrepancy principle to
judge a weight per pixel, so the weight is chosen for many pixels at once: pooled over
a scan's pixels (one relative smoothness for all, each pixel's weight following its own
noise), or per mean spectrum, whose noise is its pixels' over their count.
:data:`CHOICE_RULES` lists the rules. A mean is judged by REML. A scan's per-pixel
strength is judged by the pooled discrepancy principle: pooled REML chose a weaker
smoothing and scored worse against the bench's hidden scene (the curvature prior is a
poor model of a single pixel's spectrum, so its likelihood under-smooths; measured:
``docs/notes/2026-11-29-docstring-measurements.md``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import ProcedureError, step_error

__all__ = ["CHOICE_RULES", "RegularisationChoice", "rule_scores"]

#: Rules that score a regularisation weight (lower is better).
CHOICE_RULES = ("reml", "gcv", "discrepancy")


def rule_scores(
    rule: str,
    coords: NDArray[np.floating],
    gains: NDArray[np.floating],
    eigenvalues: NDArray[np.floating],
    weights: NDArray[np.floating],
    variance: NDArray[np.floating],
    shift: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Per-spectrum terms of a rule at the given weights.

    Parameters
    ----------
    rule
        One of :data:`CHOICE_RULES`.
    coords, gains, eigenvalues
        (N, B') ``c``, ``d`` and ``lambda`` of each spectrum (its field point's).
    weights
        (N,) ``alpha`` of each spectrum.
    variance
        (N,) noise variance of one column sum of each spectrum (white across bins).
    shift
        ``a0``, the weight the eigenvectors were computed at.

    Returns
    -------
    score, residual, dof : ndarray
        (N,) each: the rule's own per-spectrum score (REML: ``-2 log L``; the other rules
        are pooled by :meth:`RegularisationChoice.pooled` from ``residual`` and the
        residual's degrees of freedom ``m - trace H``).

    Examples
    --------
    >>> c, d, lam = np.array([[3.0, 0.1]]), np.ones((1, 2)), np.array([[0.0, 10.0]])
    >>> score, residual, dof = rule_scores("reml", c, d, lam, np.array([1.0]), np.ones(1), 0.0)
    >>> round(float(residual[0]), 5), round(float(dof[0]), 4)  # second mode damped 11x
    (0.00826, 0.9091)
    """
    if rule not in CHOICE_RULES:
        raise ProcedureError(
            step_error(
                "spectral deblur",
                f"unknown regularisation rule {rule!r}",
                f"use one of {', '.join(CHOICE_RULES)}",
            )
        )
    alpha = np.asarray(weights, dtype=np.float64)[:, None]
    filt = 1.0 / (1.0 + (alpha - shift) * eigenvalues)
    safe_d = np.where(gains > 0, gains, 1.0)
    square = coords**2 / safe_d
    residual = np.sum(square * (1.0 - filt * gains) ** 2, axis=1)
    dof = gains.shape[1] - np.sum(filt * gains, axis=1)
    if rule == "reml":
        penalised = eigenvalues > 1e-12 * np.max(eigenvalues, axis=1, keepdims=True)
        lam = np.where(penalised, eigenvalues, 1.0)
        v = np.asarray(variance, dtype=np.float64)[:, None] * (1.0 + safe_d / (alpha * lam))
        score = np.sum(np.where(penalised, np.log(v) + square / v, 0.0), axis=1)
    else:
        score = residual
    return score, residual, dof


@dataclass(frozen=True)
class RegularisationChoice:
    """How a deblur's regularisation was chosen, so a cube or a bundle can be reproduced.

    Attributes
    ----------
    rule
        The rule (:data:`CHOICE_RULES`), or ``"fixed"`` when the value was given.
    parameter
        What was chosen: ``"smoothness"`` (a scan's relative roughness, each pixel's
        weight following its own noise) or ``"weight"`` (one weight per mean spectrum).
    value
        The chosen value (for per-mean weights: their median).
    candidates, scores
        The values tried and their pooled scores (empty when fixed).
    spectra
        How many spectra (pixels or means) judged the choice.
    guard_weight
        The ridge on the guard bins beyond the band, when it was chosen too.
    prior
        The penalty: ``"curvature"`` or ``"curvature relative to the scan's mean"``.
    """

    rule: str
    parameter: str
    value: float
    candidates: tuple[float, ...] = ()
    scores: tuple[float, ...] = ()
    spectra: int = 0
    guard_weight: float | None = None
    prior: str = "curvature"

    @staticmethod
    def pooled(
        rule: str,
        score: NDArray[np.float64],
        residual: NDArray[np.float64],
        dof: NDArray[np.float64],
        variance: NDArray[np.float64],
        bins: int,
    ) -> NDArray[np.float64]:
        """One score per candidate from per-spectrum terms, (K,); lower is better.

        ``score``, ``residual`` and ``dof`` are (K, N) from :func:`rule_scores` at each
        candidate; ``variance`` (N,).

        Examples
        --------
        >>> res = np.array([[1.0, 1.0], [4.0, 4.0]])
        >>> RegularisationChoice.pooled("discrepancy", res, res, res, np.ones(2), 2).tolist()
        [2.0, 4.0]
        """
        if rule == "reml":
            return np.sum(score, axis=1)
        if rule == "gcv":
            n = residual.shape[1]
            return n * bins * np.sum(residual, axis=1) / np.sum(dof, axis=1) ** 2
        expected = bins * np.sum(variance)
        return np.abs(np.sum(residual, axis=1) - expected)

    def to_attrs(self, prefix: str = "deblur_") -> dict[str, Any]:
        """Flat attributes (NetCDF, JSON): strings and numbers, lists as arrays.

        Examples
        --------
        >>> choice = RegularisationChoice("reml", "smoothness", 0.02, (0.01, 0.02), (5.0, 3.0), 9)
        >>> attrs = choice.to_attrs()
        >>> attrs["deblur_rule"], attrs["deblur_smoothness"], attrs["deblur_spectra"]
        ('reml', 0.02, 9)
        """
        attrs: dict[str, Any] = {
            f"{prefix}rule": self.rule,
            f"{prefix}prior": self.prior,
            f"{prefix}{self.parameter}": float(self.value),
            f"{prefix}spectra": int(self.spectra),
        }
        if self.candidates:
            attrs[f"{prefix}candidates"] = np.asarray(self.candidates, dtype=np.float64)
            attrs[f"{prefix}scores"] = np.asarray(self.scores, dtype=np.float64)
        if self.guard_weight is not None:
            attrs[f"{prefix}guard_weight"] = float(self.guard_weight)
        return attrs

    def to_dict(self) -> dict[str, Any]:
        """The choice as JSON-ready data (a bundle's procedure record, a report)."""
        return {
            "rule": self.rule,
            "parameter": self.parameter,
            "value": float(self.value),
            "candidates": [float(v) for v in self.candidates],
            "scores": [float(v) for v in self.scores],
            "spectra": int(self.spectra),
            "guard_weight": None if self.guard_weight is None else float(self.guard_weight),
            "prior": self.prior,
        }
