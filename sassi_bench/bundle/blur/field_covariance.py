"""The field-covariance blur: an elliptical spot that grows and turns over the SLM.

Real optics (astigmatism, coma, field curvature) make the spot change size, shape and
orientation over the field, by a factor of 2-8 on catalogue-lens arms; a round
``sigma(λ)`` misses such a spot by 0.4 px (achromats) to 1.2 px (singlets). This form
holds the spot's covariance, ``cxx`` along the streak (camera columns), ``cyy`` across it
and ``cxy``, each a 2-D Legendre series over the SLM (the field maps' basis) whose
coefficients are polynomials in a wavelength coordinate ``t``: ``(λ - lambda_ref_nm) /
lambda_scale_nm`` (``wavelength_coordinate: wavelength``, the default) or the same scaled
to first order but linear in ``1/λ²`` (``inverse_square``: a lens's chromatic focal shift
follows its glasses' index, which a Cauchy term in ``1/λ²`` describes, so the spot is a
gentler function of it). Past the measured band (``band_nm``, when given) each component
continues along its tangent at the band's end instead of as the polynomial. The
covariance, not the widths and their correlation, is what is fitted and interpolated:
the correlation is ill-conditioned near astigmatic line foci, where one width is small.

Like ``psf_quadratic`` the spot is before the camera pixel: the optics' PSF plus the SLM
pixel's image (``pixel_variance_px2``, each axis).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle.blur.model import BLUR_FORMS, BlurModel, Spot
from sassi_bench.bundle.model_checks import bad, real, reals
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design, legendre2d_terms

__all__ = ["WAVELENGTH_COORDINATES", "FieldCovarianceBlur", "wavelength_terms"]

#: The wavelength coordinates a field blur's series may be written in.
WAVELENGTH_COORDINATES = ("wavelength", "inverse_square")

#: The smallest variance (camera px**2) a component is allowed, so widths stay real.
_MIN_VARIANCE = 0.04**2
#: The correlation is kept inside this, so the covariance stays positive definite.
_MAX_CORRELATION = 0.98
#: Field points (columns x rows) :meth:`FieldCovarianceBlur.sigma` takes its widest over.
_WIDEST_GRID = (17, 11)


def wavelength_terms(
    wavelength_nm: ArrayLike,
    degree: int,
    lambda_ref_nm: float,
    lambda_scale_nm: float,
    coordinate: str = "wavelength",
    band_nm: tuple[float, float] | None = None,
) -> NDArray[np.float64]:
    """The wavelength series' terms ``1, t, ..., t**degree`` at each wavelength, (..., degree + 1).

    ``t`` is ``(λ - lambda_ref_nm) / lambda_scale_nm`` (``coordinate="wavelength"``) or
    ``(1 - (lambda_ref_nm / λ)²) lambda_ref_nm / (2 lambda_scale_nm)``
    (``"inverse_square"``: linear in ``1/λ²``, equal to the first to first order at the
    reference). Outside ``band_nm`` each term continues along its tangent at the nearer
    end, so a series fitted inside the band is extrapolated linearly in ``t``.

    Examples
    --------
    >>> wavelength_terms([550.0, 700.0], 2, 550.0, 150.0).round(3).tolist()
    [[1.0, 0.0, 0.0], [1.0, 1.0, 1.0]]
    >>> wavelength_terms([700.0], 2, 550.0, 150.0, band_nm=(450.0, 670.0)).round(3).tolist()
    [[1.0, 1.0, 0.96]]
    """
    lam = np.asarray(wavelength_nm, dtype=np.float64)

    def coordinate_of(lam: NDArray[np.float64]) -> NDArray[np.float64]:
        if coordinate == "inverse_square":
            return (1.0 - (lambda_ref_nm / lam) ** 2) * lambda_ref_nm / (2.0 * lambda_scale_nm)
        return (lam - lambda_ref_nm) / lambda_scale_nm

    t = coordinate_of(lam)
    powers = np.arange(degree + 1)
    if band_nm is None:
        return t[..., None] ** powers
    inside = np.clip(t, *np.sort(coordinate_of(np.asarray(band_nm, dtype=np.float64))))
    slope = powers * inside[..., None] ** np.maximum(powers - 1, 0)
    return inside[..., None] ** powers + slope * (t - inside)[..., None]


@BLUR_FORMS.register("field_covariance")
@dataclass(frozen=True, eq=False)
class FieldCovarianceBlur(BlurModel):
    """The spot's covariance over the field and wavelength.

    Parameters
    ----------
    coeffs
        (3, field terms, wavelength degree + 1): the series of ``cxx``, ``cyy``, ``cxy``
        (camera px**2); field terms in :func:`~sassi_bench.maths.legendre.legendre2d_terms`
        order, powers of ``t`` ascending.
    field_degree
        Total degree of the field series.
    slm_shape
        SLM (height, width): the field's normalisation.
    lambda_ref_nm, lambda_scale_nm
        The reference and scale of the wavelength coordinate ``t``
        (:func:`wavelength_terms`).
    window_sigmas
        Half-width of the summation window in units of sigma.
    pixel_variance_px2
        The SLM pixel's image's variance (camera px**2) inside the spot.
    relative_error
        The fit's own estimate of its error, as a fraction of the width (None: unstated).
    wavelength_coordinate
        ``"wavelength"`` (the series in ``λ``; bundles without the key) or
        ``"inverse_square"`` (in ``1/λ²``).
    band_nm
        (low, high) wavelengths the series holds between; past them it continues linearly
        in ``t`` (None: the polynomial everywhere).

    Examples
    --------
    >>> coeffs = np.zeros((3, 3, 2))
    >>> coeffs[0, 0] = [1.0, 0.5]   # cxx = 1 + 0.5 t
    >>> coeffs[1, 0, 0] = 0.25      # cyy = 0.25
    >>> coeffs[2, 1, 0] = 0.2       # cxy = 0.2 u_hat
    >>> blur = FieldCovarianceBlur(coeffs, 1, (200, 320), 550.0, 150.0, 3.0, 0.07)
    >>> spot = blur.spot([0, 319], [100, 100], 550.0)
    >>> spot.along.round(3).tolist(), spot.across.round(3).tolist()
    ([1.0, 1.0], [0.5, 0.5])
    >>> spot.correlation.round(3).tolist()
    [-0.4, 0.4]
    >>> bool(blur.sigma(700.0) > 1.2)
    True
    """

    coeffs: NDArray[np.float64]
    field_degree: int
    slm_shape: tuple[int, int]
    lambda_ref_nm: float
    lambda_scale_nm: float
    window_sigmas: float
    pixel_variance_px2: float = 0.0
    relative_error: float | None = None
    wavelength_coordinate: str = "wavelength"
    band_nm: tuple[float, float] | None = None

    def __post_init__(self) -> None:
        where = "models.blur"
        coeffs = np.array(self.coeffs, dtype=np.float64)
        degree = self.field_degree
        if isinstance(degree, bool) or not isinstance(degree, int | np.integer) or degree < 0:
            raise bad(f"{where}.field_degree", f"must be an integer >= 0, got {degree!r}")
        terms = len(legendre2d_terms(int(degree)))
        if coeffs.ndim != 3 or coeffs.shape[:2] != (3, terms) or coeffs.shape[2] < 1:
            raise bad(
                f"{where}.covariance_coeffs",
                f"must be 3 x {terms} x (wavelength degree + 1) numbers, got shape {coeffs.shape}",
            )
        if not np.all(np.isfinite(coeffs)):
            raise bad(f"{where}.covariance_coeffs", "holds a non-finite number")
        coeffs.setflags(write=False)
        object.__setattr__(self, "coeffs", coeffs)
        object.__setattr__(self, "field_degree", int(degree))
        shape = tuple(int(s) for s in self.slm_shape)
        if len(shape) != 2 or min(shape) < 2:
            raise bad(f"{where}.slm_shape", f"must be [height, width], got {self.slm_shape!r}")
        object.__setattr__(self, "slm_shape", shape)
        for key in ("lambda_ref_nm", "lambda_scale_nm", "window_sigmas"):
            positive = key != "lambda_ref_nm"
            object.__setattr__(
                self, key, real(getattr(self, key), f"{where}.{key}", positive=positive)
            )
        self._check_pixel_and_error(where)
        if self.wavelength_coordinate not in WAVELENGTH_COORDINATES:
            raise bad(
                f"{where}.wavelength_coordinate",
                f"must be one of {', '.join(WAVELENGTH_COORDINATES)}, "
                f"got {self.wavelength_coordinate!r}",
            )
        if self.band_nm is not None:
            low, high = reals(self.band_nm, 2, f"{where}.band_nm")
            if not 0 < low < high:
                raise bad(f"{where}.band_nm", f"must be [low, high] with 0 < low < high, got "
                          f"{list(self.band_nm)}")  # fmt: skip
            object.__setattr__(self, "band_nm", (low, high))

    @property
    def kind(self) -> str:
        """The manifest's ``model``: ``"field_covariance"``."""
        return "field_covariance"

    def covariance(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The spot's covariance (cxx, cyy, cxy; camera px**2) at (u, v, λ), broadcast."""
        u_hat, v_hat = field_coordinates(u, v, self.slm_shape)
        basis = legendre2d_design(u_hat, v_hat, self.field_degree)  # (..., terms)
        powers = self.wavelength_terms(wavelength_nm)  # (..., degree + 1)
        shape = np.broadcast_shapes(basis.shape[:-1], powers.shape[:-1])
        basis = np.broadcast_to(basis, (*shape, basis.shape[-1]))
        powers = np.broadcast_to(powers, (*shape, powers.shape[-1]))
        out = np.einsum("...f,cfl,...l->c...", basis, self.coeffs, powers, optimize=True)
        # The spot holds the SLM pixel's image: never narrower than that on either axis
        # (a fit extrapolated past its lasers can dive below it).
        floor = max(_MIN_VARIANCE, self.pixel_variance_px2)
        cxx = np.maximum(out[0], floor)
        cyy = np.maximum(out[1], floor)
        limit = _MAX_CORRELATION * np.sqrt(cxx * cyy)
        return cxx, cyy, np.clip(out[2], -limit, limit)

    def wavelength_terms(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The wavelength series' terms at each wavelength (:func:`wavelength_terms`)."""
        return wavelength_terms(
            wavelength_nm, self.coeffs.shape[2] - 1, self.lambda_ref_nm, self.lambda_scale_nm,
            self.wavelength_coordinate, self.band_nm,
        )  # fmt: skip

    def spot(self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike) -> Spot:
        """Widths along and across the streak and their correlation at (u, v, λ)."""
        cxx, cyy, cxy = self.covariance(u, v, wavelength_nm)
        along, across = np.sqrt(cxx), np.sqrt(cyy)
        return Spot(along, across, cxy / (along * across))

    def sigma(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The widest spot's major-axis sigma over the SLM at each wavelength (camera px)."""
        lam = np.asarray(wavelength_nm, dtype=np.float64)
        h, w = self.slm_shape
        u, v = np.meshgrid(
            np.linspace(0, w - 1, _WIDEST_GRID[0]), np.linspace(0, h - 1, _WIDEST_GRID[1])
        )
        cxx, cyy, cxy = self.covariance(
            u.reshape(-1, *([1] * lam.ndim)), v.reshape(-1, *([1] * lam.ndim)), lam[None]
        )
        major = 0.5 * (cxx + cyy) + np.sqrt(0.25 * (cxx - cyy) ** 2 + cxy**2)
        return np.sqrt(major.max(axis=0))

    def psf(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike, *, slm_pixel_variance_px2: float
    ) -> Spot:
        """The optics' PSF: the spot without the SLM pixel's image (at least 0.2 px)."""
        cxx, cyy, cxy = self.covariance(u, v, wavelength_nm)
        pixel = self.pixel_variance_px2 if self.pixel_variance_px2 > 0 else slm_pixel_variance_px2
        along = np.sqrt(np.clip(cxx - pixel, 0.04, None))
        across = np.sqrt(np.clip(cyy - pixel, 0.04, None))
        return Spot(
            along, across, np.clip(cxy / (along * across), -_MAX_CORRELATION, _MAX_CORRELATION)
        )

    def to_manifest(self) -> dict[str, Any]:
        """The ``models.blur`` entry."""
        entry: dict[str, Any] = {
            "model": self.kind,
            "covariance_coeffs": self.coeffs.tolist(),
            "field_degree": self.field_degree,
            "slm_shape": list(self.slm_shape),
            "lambda_ref_nm": self.lambda_ref_nm,
            "lambda_scale_nm": self.lambda_scale_nm,
            "window_sigmas": self.window_sigmas,
            "pixel_variance_px2": self.pixel_variance_px2,
            "wavelength_coordinate": self.wavelength_coordinate,
        }
        if self.band_nm is not None:
            entry["band_nm"] = list(self.band_nm)
        if self.relative_error is not None:
            entry["relative_error"] = self.relative_error
        return entry

    @classmethod
    def from_entry(cls, entry: dict[str, Any]) -> FieldCovarianceBlur:
        """Build from a ``models.blur`` entry of model ``"field_covariance"``."""
        keys = (
            "covariance_coeffs",
            "field_degree",
            "slm_shape",
            "lambda_ref_nm",
            "lambda_scale_nm",
        )
        missing = [key for key in keys if key not in entry]
        if missing:
            raise bad("models.blur", f"lacks {', '.join(missing)}")
        return cls(
            coeffs=np.asarray(entry["covariance_coeffs"], dtype=np.float64),
            field_degree=entry["field_degree"],
            slm_shape=tuple(entry["slm_shape"]),
            lambda_ref_nm=entry["lambda_ref_nm"],
            lambda_scale_nm=entry["lambda_scale_nm"],
            window_sigmas=entry["window_sigmas"],
            pixel_variance_px2=entry.get("pixel_variance_px2", 0.0),
            relative_error=entry.get("relative_error"),
            wavelength_coordinate=entry.get("wavelength_coordinate", "wavelength"),
            band_nm=entry.get("band_nm"),
        )
