"""The calibration models a bundle holds, and how they are evaluated (the model contract).

This module is the single definition of the model content shared by the fitting code (which
builds these objects and publishes them) and by every consumer (which loads them). The
manifest's ``models`` section and the arrays it names are produced by
:meth:`CalibrationModels.to_manifest` and read back by :meth:`CalibrationModels.from_manifest`.
The required models are the types of :mod:`sassi_bench.bundle.model_types`; the field
basis is computed by :mod:`sassi_bench.maths.legendre`.

Coordinates: SLM pixel ``(u, v)`` = (column, row), camera pixel ``(x, y)``, wavelength ``λ`` in
nm; pixel centres at integer coordinates.

Dispersion (``models.dispersion``)
    ``{"glass", "sellmeier_b": [B1, B2, B3], "sellmeier_c": [C1, C2, C3] (µm²), "n_ref",
    "n_scale", "field_basis": "legendre2d", "field_degree": D, "slm_shape": [H, W],
    "x_coeffs": <array>, "lambda_ref_nm", "lambda_scale_nm", "y_coeffs": <array>,
    "y_index_coeffs": <array> (optional, schema 1.1)}``.

    * refractive index ``n(λ) = sqrt(1 + Σ_i B_i λ² / (λ² − C_i))``, ``λ`` in µm;
    * spectral variables ``s_x = (n(λ) − n_ref) / n_scale`` and
      ``s_y = (λ − lambda_ref_nm) / lambda_scale_nm``;
    * field coordinates ``û = 2u / (W − 1) − 1``, ``v̂ = 2v / (H − 1) − 1`` (−1..1 over the SLM);
    * field basis: the products ``P_i(û) P_j(v̂)`` of Legendre polynomials for all
      ``i + j <= D``, ordered by total degree, then ``i`` descending
      (:func:`~sassi_bench.maths.legendre.legendre2d_terms`);
    * arrays ``x_coeffs`` and ``y_coeffs`` of shape ``(K, n_terms)`` (``K = 3`` for the
      quadratic fit): ``x(u, v, λ) = Σ_k Σ_t x_coeffs[k, t] basis_t(û, v̂) s_x^k`` and
      ``y(u, v, λ) = Σ_k Σ_t y_coeffs[k, t] basis_t(û, v̂) s_y^k`` (the paper's row);
    * when ``y_index_coeffs`` (same shape) is given, the row is a polynomial in the index
      instead, ``y(u, v, λ) = Σ_k Σ_t y_index_coeffs[k, t] basis_t(û, v̂) s_x^k``, and
      ``y_coeffs`` is kept for readers of schema 1.0 (which ignore the new key).

Wavelength bins (``models.wavelength_bins``)
    Names of three arrays: ``bin_centres_nm`` ``(B,)``, ``bin_edges_nm`` ``(B + 1,)`` (strictly
    increasing, each centre inside its bin) and ``bin_resolution_nm`` ``(B,)``.

Blur (``models.blur``)
    ``{"model": "quadratic", "coeffs": [c0, c1, c2], "lambda_ref_nm", "lambda_scale_nm",
    "window_sigmas"}``: Gaussian ``sigma(λ) = c0 + c1 t + c2 t²`` camera px with
    ``t = (λ − lambda_ref_nm) / lambda_scale_nm``; the half-width of the summation window is
    ``window_sigmas · sigma(λ)`` rows. ``sigma`` must be positive over the bins.
    ``{"model": "psf_quadratic", ..., "pixel_variance_px2": p}``: the quadratic is the optics'
    PSF and ``sigma(λ) = sqrt(quadratic² + p)`` (the pixel boxes' variance ``p`` px² added).
    Either may state ``"relative_error"``: the fit's estimate of how far ``sigma`` may be
    off between the lasers (a fraction), which a deblur weighs as the forward model's error.

Guide homography (``models.guide_homography``, optional)
    ``{"array": <3x3 array>, "rms_px": ..., ...}`` or null. The 3x3 matrix maps guide pixels
    ``(p, q, 1)`` to SLM pixels ``(u, v, 1)`` (homogeneous coordinates).

Offset (``models.offset``, optional)
    Free parameters of the background-offset model, e.g. ``{"method": "masked-cubic", ...}``,
    or null.

Response (``models.response``, optional)
    ``{"array": <(B,) array>}``: the per-bin system response, or null.

Optional models may be null or absent; a model that is present must follow the contract, or
:class:`~sassi_bench.bundle.errors.BundleSchemaError` is raised.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle.blur import BlurModel, blur_from_manifest
from sassi_bench.bundle.jsonio import freeze, thaw, to_jsonable
from sassi_bench.bundle.model_checks import array_ref, bad, frozen_array, mapping, real
from sassi_bench.bundle.model_types import DispersionModel, WavelengthBins

__all__ = ["CalibrationModels"]

#: Field points (û, v̂) where the dispersion is checked: corners, edge midpoints, centre.
_CHECK_FIELD = np.array([(a, b) for a in (-1.0, 0.0, 1.0) for b in (-1.0, 0.0, 1.0)])
_CHECK_SAMPLES = 257


@dataclass(frozen=True, eq=False)
class CalibrationModels:
    """Every model of a calibration, checked for consistency with each other.

    Parameters
    ----------
    dispersion, bins, blur
        The required models.
    guide_to_slm
        3x3 guide -> SLM homography, or None if the guide camera was not calibrated.
    guide_info
        Extra facts about the homography fit (``{"rms_px": 0.3, "matches": 812}``).
    offset
        Parameters of the background-offset model (``{"method": "masked-cubic", ...}``) or None.
    response
        ``(B,)`` per-bin system response or None.

    Raises
    ------
    BundleSchemaError
        If a model breaks the contract, e.g. blur sigma <= 0 or a non-monotonic streak
        somewhere over the bins' wavelength range.

    Examples
    --------
    >>> m = bundle.models  # a loaded bundle's
    >>> models = CalibrationModels(m.dispersion, m.bins, m.blur)
    >>> entry, arrays = models.to_manifest()
    """

    dispersion: DispersionModel
    bins: WavelengthBins
    blur: BlurModel
    guide_to_slm: NDArray[np.float64] | None = None
    guide_info: Mapping[str, Any] = field(default_factory=dict)
    offset: Mapping[str, Any] | None = None
    response: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        for name, kind in (
            ("dispersion", DispersionModel),
            ("bins", WavelengthBins),
            ("blur", BlurModel),
        ):
            if not isinstance(getattr(self, name), kind):
                raise bad(f"models.{name}", f"must be a {kind.__name__}")
        bins = self.bins
        if self.guide_to_slm is not None:
            matrix = frozen_array(self.guide_to_slm, "models.guide_homography", (3, 3))
            if not abs(np.linalg.det(matrix)) > 1e-12 * max(1.0, float(np.abs(matrix).max()) ** 3):
                raise bad("models.guide_homography", "is singular")
            object.__setattr__(self, "guide_to_slm", matrix)
        info = to_jsonable(
            dict(mapping(self.guide_info, "models.guide_homography")),
            "models.guide_homography",
            "models",
        )
        if "array" in info:
            raise bad("models.guide_homography", "info must not hold the key 'array'")
        if "rms_px" in info:
            real(info["rms_px"], "models.guide_homography.rms_px")
        object.__setattr__(self, "guide_info", freeze(info))
        if self.offset is not None:
            offset = to_jsonable(
                dict(mapping(self.offset, "models.offset")), "models.offset", "models"
            )
            if not isinstance(offset.get("method"), str) or not offset["method"]:
                raise bad("models.offset.method", "must be a non-empty string")
            object.__setattr__(self, "offset", freeze(offset))
        if self.response is not None:
            response = frozen_array(
                self.response,
                "models.response",
                (bins.count,),
                expected_for=f"{bins.count} wavelength bins",
            )
            if np.any(response < 0):
                raise bad("models.response", "must be >= 0")
            object.__setattr__(self, "response", response)
        self._check_over_range()

    def _check_over_range(self) -> None:
        """Sample the models over the bins' range: sigma > 0, valid index, monotonic streaks."""
        lo, hi = float(self.bins.edges_nm[0]), float(self.bins.edges_nm[-1])
        lam = np.union1d(np.linspace(lo, hi, _CHECK_SAMPLES), self.bins.edges_nm)
        with np.errstate(all="ignore"):
            sigma = self.blur.sigma(lam)
            if not np.all(np.isfinite(sigma) & (sigma > 0)):
                raise bad("models.blur", f"sigma must be > 0 over the bins ({lo:g}-{hi:g} nm)")
            n = self.dispersion.index(lam)
            if not np.all(np.isfinite(n) & (n > 1)):
                raise bad(
                    "models.dispersion.sellmeier_b",
                    f"give no valid refractive index over the bins ({lo:g}-{hi:g} nm)",
                )
            height, width = self.dispersion.slm_shape
            u = (_CHECK_FIELD[:, 0] + 1.0) * (width - 1) / 2.0
            v = (_CHECK_FIELD[:, 1] + 1.0) * (height - 1) / 2.0
            x, y = self.dispersion.evaluate(u[:, None], v[:, None], lam[None, :])
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
                raise bad("models.dispersion", "is not finite over the field and the bins")
            steps = np.diff(x, axis=1)
            if not (np.all(steps > 0) or np.all(steps < 0)):
                raise bad(
                    "models.dispersion.x_coeffs",
                    "give streaks whose camera x is not monotonic in wavelength over the field "
                    f"and the bins ({lo:g}-{hi:g} nm)",
                )

    def to_manifest(self) -> tuple[dict[str, Any], dict[str, NDArray[np.float64]]]:
        """The manifest's ``models`` section and the arrays it names.

        Examples
        --------
        >>> section, arrays = bundle.models.to_manifest()
        >>> sorted(section)
        ['blur', 'dispersion', 'guide_homography', 'offset', 'response', 'wavelength_bins']
        """
        dispersion, arrays = self.dispersion.to_manifest()
        bins, bin_arrays = self.bins.to_manifest()
        arrays.update(bin_arrays)
        section: dict[str, Any] = {
            "dispersion": dispersion,
            "wavelength_bins": bins,
            "blur": self.blur.to_manifest(),
            "guide_homography": None,
            "offset": None if self.offset is None else thaw(self.offset),
            "response": None,
        }
        if self.guide_to_slm is not None:
            section["guide_homography"] = {"array": "guide_to_slm", **thaw(self.guide_info)}
            arrays["guide_to_slm"] = self.guide_to_slm
        if self.response is not None:
            section["response"] = {"array": "response"}
            arrays["response"] = self.response
        return section, arrays

    @classmethod
    def from_manifest(cls, section: Any, arrays: Mapping[str, Any]) -> CalibrationModels:
        """Build from the manifest's ``models`` section and the bundle's arrays.

        Optional models (``guide_homography``, ``offset``, ``response``) may be null or absent.

        Raises
        ------
        BundleSchemaError
            If a model is malformed or names an array the bundle does not hold.
        """
        section = mapping(section, "models")
        guide = section.get("guide_homography")
        guide_matrix = None
        guide_info: dict[str, Any] = {}
        if guide is not None:
            guide = mapping(guide, "models.guide_homography")
            guide_matrix = array_ref(guide, "array", arrays, "models.guide_homography")
            guide_info = {key: value for key, value in guide.items() if key != "array"}
        response = section.get("response")
        if response is not None:
            response = array_ref(
                mapping(response, "models.response"), "array", arrays, "models.response"
            )
        offset = section.get("offset")
        if offset is not None:
            offset = mapping(offset, "models.offset")
        return cls(
            dispersion=DispersionModel.from_manifest(section.get("dispersion"), arrays),
            bins=WavelengthBins.from_manifest(section.get("wavelength_bins"), arrays),
            blur=blur_from_manifest(section.get("blur")),
            guide_to_slm=guide_matrix,
            guide_info=thaw(guide_info),
            offset=thaw(offset) if offset is not None else None,
            response=response,
        )
