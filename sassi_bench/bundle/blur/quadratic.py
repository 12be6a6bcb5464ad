"""The quadratic blur: a round Gaussian spot, the same over the field, its width a
quadratic in wavelength (the SASSI paper's curve).

``"psf_quadratic"`` (what the calibration fits): the quadratic is the optics' PSF and the
spot adds the SLM pixel's image in quadrature, ``sqrt(psf(λ)² + pixel_variance_px2)``;
``"quadratic"`` (older bundles): the quadratic is the measured spot width itself, camera
pixel included.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.polynomial import polynomial
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle.blur.model import BLUR_FORMS, BlurModel, Spot
from sassi_bench.bundle.model_checks import bad, real, reals

__all__ = ["QuadraticBlur"]


@BLUR_FORMS.register("psf_quadratic", "quadratic")
@dataclass(frozen=True, eq=False)
class QuadraticBlur(BlurModel):
    """Wavelength-dependent Gaussian blur: ``sigma(λ) = c0 + c1 t + c2 t²`` (``"quadratic"``),
    or ``sigma(λ) = sqrt((c0 + c1 t + c2 t²)² + pixel_variance_px2)`` (``"psf_quadratic"``:
    the quadratic is the optics' PSF, and the SLM pixel's and camera pixel's boxes add a
    variance that does not depend on the wavelength). Round and the same over the field:
    :meth:`spot` ignores ``u`` and ``v``.

    Parameters
    ----------
    coeffs
        ``(c0, c1, c2)`` in camera px.
    lambda_ref_nm, lambda_scale_nm
        ``t = (λ − lambda_ref_nm) / lambda_scale_nm``.
    window_sigmas
        Half-width of the summation window in units of sigma.
    pixel_variance_px2
        The pixel boxes' variance (camera px²); 0 (the default) is the plain quadratic.
    relative_error
        The fit's own estimate of how far ``sigma`` may be off between the lasers, as a
        fraction (the RMS of its leave-one-laser-out errors); None when the
        fit did not state one (older bundles, three lasers).

    Examples
    --------
    >>> blur = QuadraticBlur((1.0, 0.0, 3.0), 520.0, 115.0, 2.5)
    >>> blur.sigma([405.0, 520.0, 635.0]).round(3).tolist()
    [4.0, 1.0, 4.0]
    >>> psf = QuadraticBlur((0.0, 0.0, 3.0), 520.0, 115.0, 2.5, pixel_variance_px2=16.0)
    >>> psf.sigma([405.0, 520.0]).round(3).tolist()
    [5.0, 4.0]
    >>> psf.spot([0, 600], [0, 300], 405.0).across.round(3).tolist()  # the same everywhere
    [5.0, 5.0]
    """

    coeffs: tuple[float, float, float]
    lambda_ref_nm: float
    lambda_scale_nm: float
    window_sigmas: float
    pixel_variance_px2: float = 0.0
    relative_error: float | None = None

    def __post_init__(self) -> None:
        where = "models.blur"
        object.__setattr__(self, "coeffs", reals(self.coeffs, 3, f"{where}.coeffs"))
        object.__setattr__(
            self, "lambda_ref_nm", real(self.lambda_ref_nm, f"{where}.lambda_ref_nm")
        )
        object.__setattr__(
            self,
            "lambda_scale_nm",
            real(self.lambda_scale_nm, f"{where}.lambda_scale_nm", positive=True),
        )
        object.__setattr__(
            self,
            "window_sigmas",
            real(self.window_sigmas, f"{where}.window_sigmas", positive=True),
        )
        self._check_pixel_and_error(where)

    @property
    def kind(self) -> str:
        """The manifest's ``model``: ``"quadratic"`` or ``"psf_quadratic"``."""
        return "psf_quadratic" if self.pixel_variance_px2 > 0 else "quadratic"

    def sigma(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Gaussian sigma in camera px at ``wavelength_nm`` (vectorised)."""
        t = (np.asarray(wavelength_nm, dtype=np.float64) - self.lambda_ref_nm) / (
            self.lambda_scale_nm
        )
        value = np.asarray(polynomial.polyval(t, self.coeffs), dtype=np.float64)
        if self.pixel_variance_px2 > 0:
            value = np.sqrt(value**2 + self.pixel_variance_px2)
        return value

    def spot(self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike) -> Spot:
        """The round spot of :meth:`sigma`, at every point: ``u`` and ``v`` only shape it
        (the widths are the wavelengths' broadcast, not copied)."""
        lam = np.asarray(wavelength_nm, dtype=np.float64)
        shape = np.broadcast_shapes(np.shape(u), np.shape(v), lam.shape)
        return Spot.round(np.broadcast_to(self.sigma(lam), shape))

    def psf(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike, *, slm_pixel_variance_px2: float
    ) -> Spot:
        """The PSF behind the spot (at least 0.2 px): the spot without its pixel boxes (a
        ``"psf_quadratic"``'s own; for a ``"quadratic"``, the SLM pixel's image given and
        the camera pixel, which its measured widths held).

        Examples
        --------
        >>> psf = QuadraticBlur((0.5, 0.0, 0.0), 550.0, 150.0, 3.0, pixel_variance_px2=0.08)
        >>> round(float(psf.psf(0, 0, 550.0, slm_pixel_variance_px2=0.1).along), 3)
        0.5
        >>> total = QuadraticBlur((1.0, 0.0, 0.0), 550.0, 150.0, 3.0)
        >>> round(float(total.psf(0, 0, 550.0, slm_pixel_variance_px2=0.0).along), 3)
        0.957
        """
        spot = np.asarray(self.spot(u, v, wavelength_nm).along, dtype=np.float64)
        if self.kind == "psf_quadratic":
            pixels2 = self.pixel_variance_px2
        else:
            pixels2 = slm_pixel_variance_px2 + 1.0 / 12.0
        return Spot.round(np.sqrt(np.clip(spot**2 - pixels2, 0.04, None)))

    def to_manifest(self) -> dict[str, Any]:
        """The ``models.blur`` entry."""
        entry = {
            "model": self.kind,
            "coeffs": list(self.coeffs),
            "lambda_ref_nm": self.lambda_ref_nm,
            "lambda_scale_nm": self.lambda_scale_nm,
            "window_sigmas": self.window_sigmas,
        }
        if self.pixel_variance_px2 > 0:
            entry["pixel_variance_px2"] = self.pixel_variance_px2
        if self.relative_error is not None:
            entry["relative_error"] = self.relative_error
        return entry

    @classmethod
    def from_entry(cls, entry: dict[str, Any]) -> QuadraticBlur:
        """Build from a ``models.blur`` entry (``"quadratic"`` or ``"psf_quadratic"``)."""
        kind = entry["model"]
        keys = ["coeffs", "lambda_ref_nm", "lambda_scale_nm", "window_sigmas"]
        if kind == "psf_quadratic":
            keys.append("pixel_variance_px2")
        missing = [key for key in keys if key not in entry]
        if missing:
            raise bad("models.blur", f"lacks {', '.join(missing)}")
        return cls(
            coeffs=entry["coeffs"],
            lambda_ref_nm=entry["lambda_ref_nm"],
            lambda_scale_nm=entry["lambda_scale_nm"],
            window_sigmas=entry["window_sigmas"],
            pixel_variance_px2=entry.get("pixel_variance_px2", 0.0) if kind != "quadratic" else 0.0,
            relative_error=entry.get("relative_error"),
        )
