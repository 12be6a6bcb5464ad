"""The colour error a response's noise causes: its CIEDE2000 1-sigma on a ColorChecker.

A reflectance measured through the response is the signal over the response, so a relative
error ``e`` (B,) of the response is a relative error ``-e`` of every reflectance, bin by
bin. Its colour error is propagated, linearised, to the patches of a
:class:`ColourChart` (the caller's: the ColorChecker's reference reflectances in the
bundle's bins, with the Macbeth validation's colour matching, illuminant and CIELAB white,
``sassi_bench.workflows.scan`` builds it): reflectance to XYZ (linear), XYZ to CIELAB
(a finite-difference Jacobian at the patch) and CIELAB to CIEDE2000, whose square is
locally a quadratic form of the colour change (its matrix by finite differences of
pairs centred on the patch). With ``Sigma`` the covariance of the response's relative
error (the white's covariance between bins over its spectrum's outer product), each
patch's 1-sigma is the RMS colour error ``sqrt(trace(M J Sigma J^T))``, what the Macbeth
validation's noise floor reports for a patch.

The step's figure is the mean of the patches' 1-sigma: the Macbeth check and the rig
family's target grade the mean CIEDE2000 over the patches, so the response's noise is
measured in the statistic it adds to.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.deblur import MeanSpectrum

__all__ = [
    "ColourChart",
    "ResponseColourError",
    "de00_metric",
    "relative_covariance",
    "response_colour_error",
]

# Finite-difference steps: relative in XYZ, absolute in CIELAB units.
_XYZ_STEP = 1e-6
_LAB_STEP = 1e-3


@dataclass(frozen=True)
class ColourChart:
    """The patches a colour error is computed on, and how their colour is computed.

    Attributes
    ----------
    reflectance
        (P, B) the patches' reflectances in the bundle's bins.
    to_xyz
        (B, 3) CIE XYZ of a unit reflectance in each bin (XYZ is linear in the
        reflectance; Y of the perfect white 1).
    white_xy
        (2,) chromaticity of the illuminant: the CIELAB white.
    """

    reflectance: NDArray[np.float64]
    to_xyz: NDArray[np.float64]
    white_xy: NDArray[np.float64]

    def __post_init__(self) -> None:
        bins = np.shape(self.to_xyz)[0]
        if np.shape(self.reflectance)[-1] != bins or np.shape(self.to_xyz)[-1] != 3:
            raise ProcedureError(
                step_error(
                    "response colour error",
                    f"patch reflectances of shape {np.shape(self.reflectance)} and XYZ "
                    f"weights of shape {np.shape(self.to_xyz)} do not share the bins",
                    "build both for the bundle's bins",
                )
            )

    def lab(self, xyz: ArrayLike) -> NDArray[np.float64]:
        """CIELAB of XYZ (..., 3) under the chart's white."""
        import colour

        return np.asarray(colour.XYZ_to_Lab(xyz, self.white_xy), dtype=np.float64)


@dataclass(frozen=True)
class ResponseColourError:
    """Each patch's CIEDE2000 1-sigma (RMS) from the response's noise.

    Attributes
    ----------
    per_patch
        (24,) the RMS CIEDE2000 of each patch, reading order.
    """

    per_patch: NDArray[np.float64]

    @property
    def mean(self) -> float:
        """The mean over the patches (the step's figure)."""
        return float(np.mean(self.per_patch))

    @property
    def worst(self) -> float:
        """The worst patch's."""
        return float(np.max(self.per_patch))


def relative_covariance(white: MeanSpectrum) -> NDArray[np.float64]:
    """(B, B) covariance of the response's relative error: the white's covariance between
    the bundle's bins over its spectrum's outer product (the source is known exactly).

    Examples
    --------
    >>> white = MeanSpectrum(np.array([1.0, 2.0, 4.0, 1.0]), np.array([9.0, 0.02, 0.04, 9.0]),
    ...                      50, None, 1)
    >>> relative_covariance(white).round(6).tolist()
    [[0.0001, 0.0], [0.0, 0.0001]]
    """
    band = np.abs(white.band)
    return white.band_covariance / np.outer(band, band)


def _lab_jacobian(chart: ColourChart, xyz: NDArray[np.float64]) -> NDArray[np.float64]:
    """(N, 3, 3) d Lab / d XYZ at ``xyz`` (N, 3), central differences."""
    step = _XYZ_STEP * np.maximum(np.abs(xyz), 1e-3)  # (N, 3)
    shift = np.eye(3)[None] * step[:, None, :]  # (N, k, 3)
    diff = chart.lab(xyz[:, None, :] + shift) - chart.lab(xyz[:, None, :] - shift)
    return np.swapaxes(diff / (2.0 * step[:, :, None]), 1, 2)


def de00_metric(lab: ArrayLike) -> NDArray[np.float64]:
    """(N, 3, 3) the matrix ``M`` of CIEDE2000 squared near colours ``lab`` (N, 3):
    ``dE00(lab - d/2, lab + d/2)^2 = d^T M d`` for small CIELAB changes ``d``.

    Its entries come from pairs of colours centred on ``lab`` (so CIEDE2000's weights are
    evaluated there), the off-diagonal ones by polarisation.

    Examples
    --------
    >>> m = de00_metric([[50.0, 20.0, -10.0]])[0]
    >>> d = np.array([0.1, -0.05, 0.02])
    >>> import colour
    >>> lab = np.array([50.0, 20.0, -10.0])
    >>> exact = float(colour.delta_E(lab - d / 2, lab + d / 2, method="CIE 2000"))
    >>> bool(abs(np.sqrt(d @ m @ d) / exact - 1) < 1e-3)
    True
    """
    import colour

    lab = np.atleast_2d(np.asarray(lab, dtype=np.float64))
    eye = np.eye(3)
    off = [(0, 1), (0, 2), (1, 2)]
    # each axis, then each pair of axes summed and differenced (polarisation)
    directions = [*eye] + [eye[i] + sign * eye[j] for i, j in off for sign in (1.0, -1.0)]
    d = _LAB_STEP * np.asarray(directions)  # (9, 3)
    # colour-science's CIEDE2000, as the Macbeth validation computes it
    pair = (lab[:, None, :] - d / 2, lab[:, None, :] + d / 2)
    q = np.asarray(colour.delta_E(*pair, method="CIE 2000")) ** 2 / _LAB_STEP**2
    metric = np.empty((lab.shape[0], 3, 3))
    metric[:, range(3), range(3)] = q[:, :3]
    for n, (i, j) in enumerate(off):
        metric[:, i, j] = metric[:, j, i] = (q[:, 3 + 2 * n] - q[:, 4 + 2 * n]) / 4.0
    return metric


def response_colour_error(covariance: ArrayLike, chart: ColourChart) -> ResponseColourError:
    """Each of a chart's patches' CIEDE2000 1-sigma from a relative response error of
    ``covariance``, linearised.

    Parameters
    ----------
    covariance
        (B, B) covariance of the response's relative error (:func:`relative_covariance`).
    chart
        The patches and their colour computation, in the bundle's bins.

    Returns
    -------
    ResponseColourError

    Examples
    --------
    >>> grey = np.full((2, 30), 0.2), np.full((2, 30), 0.18)
    >>> to_xyz = np.tile([0.95, 1.0, 1.09], (30, 1)) / 30
    >>> chart = ColourChart(np.vstack(grey), to_xyz, np.array([0.3127, 0.3290]))
    >>> error = response_colour_error(1e-6 * np.eye(30), chart)  # 0.1 % per bin
    >>> error.per_patch.shape, bool(0 < error.mean < 0.1)
    ((4,), True)
    """
    cov = np.asarray(covariance, dtype=np.float64)
    refl = np.asarray(chart.reflectance, dtype=np.float64)
    to_xyz = np.asarray(chart.to_xyz, dtype=np.float64)
    if cov.shape != (to_xyz.shape[0],) * 2:
        raise ProcedureError(
            step_error(
                "response colour error",
                f"a covariance of shape {cov.shape} for {to_xyz.shape[0]} bins",
                "pass the covariance between the bundle's bins (guard bins left out)",
            )
        )
    xyz = refl @ to_xyz  # (P, 3)
    # d XYZ / d e for each patch: the bins' XYZ weights times the patch's reflectance.
    jac = _lab_jacobian(chart, xyz) @ (to_xyz.T[None] * refl[:, None, :])  # (P, 3, B)
    lab_cov = jac @ cov @ np.swapaxes(jac, 1, 2)  # (P, 3, 3)
    metric = de00_metric(chart.lab(xyz))
    variance = np.einsum("pij,pji->p", metric, lab_cov)
    return ResponseColourError(np.sqrt(np.maximum(variance, 0.0)))
