"""The blur object: the spot one SLM pixel makes on the spectral camera, as the procedures
model it.

A :class:`BlurModel` owns everything a procedure needs of the spot:

* its widths at any SLM pixel and wavelength (:meth:`BlurModel.spot`: the moment-matched
  Gaussian's sigma along the streak (camera columns) and across it (rows), and their
  correlation), the widest spot at a wavelength (:meth:`BlurModel.sigma`, what a streak's
  footprint reserves) and the optics' PSF behind it (:meth:`BlurModel.psf`, the lamp
  lines' spot model);
* its profile (:attr:`BlurModel.profile`, a :class:`GaussianProfile` for the forms so
  far): the pixel-integrated shares the fits and the compiled kernels take (a row
  interval's share, a box of columns blurred into another, an SLM pixel's image
  integrated by a camera pixel, and the CDF table of the compiled loops).

Every width is the spot *before* the camera pixel: its users integrate the profile over
camera pixels themselves. A form is one subclass registered in :data:`BLUR_FORMS` under
the name the bundle's manifest gives it (``models.blur.model``); its module in this
package is found by the registry, and :func:`blur_from_manifest` builds it. A form whose
spot changes over the field or with direction answers :meth:`BlurModel.spot` per point;
the forms so far ignore ``u`` and ``v`` and are round.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ndtr

from sassi_bench._shared.registry import Registry
from sassi_bench.bundle.model_checks import bad, mapping, real
from sassi_bench.maths.normal import NORMAL_CDF_TABLE, box_overlap, pixel_spot

__all__ = ["BLUR_FORMS", "GAUSSIAN", "BlurModel", "GaussianProfile", "Spot", "blur_from_manifest"]

#: Blur forms by their manifest name (``models.blur.model``).
BLUR_FORMS: Registry[BlurModel] = Registry("blur form", "sassi_bench.bundle.blur")


@dataclass(frozen=True, eq=False)
class Spot:
    """A spot's moment-matched Gaussian at each point (arrays of one shape).

    Attributes
    ----------
    along, across
        Sigma along the streak (camera columns) and across it (rows), camera px.
    correlation
        Correlation of the two directions (0 for a spot whose axes are the camera's).
    """

    along: NDArray[np.float64]
    across: NDArray[np.float64]
    correlation: NDArray[np.float64]

    @classmethod
    def round(cls, sigma: ArrayLike) -> Spot:
        """A round spot of width ``sigma``.

        Examples
        --------
        >>> Spot.round([1.0, 2.0]).across.tolist()
        [1.0, 2.0]
        """
        sigma = np.asarray(sigma, dtype=np.float64)
        return cls(sigma, sigma, np.broadcast_to(np.float64(0.0), sigma.shape))


class GaussianProfile:
    """A Gaussian spot's pixel-integrated shares (see :mod:`sassi_bench.maths.normal`)."""

    #: The profile's CDF as the compiled loops take it.
    cdf_table = NORMAL_CDF_TABLE

    @staticmethod
    def cdf(z: ArrayLike) -> NDArray[np.float64]:
        """The profile's share below ``z`` sigmas from its centre.

        Examples
        --------
        >>> float(GAUSSIAN.cdf(0.0))
        0.5
        """
        return ndtr(z)

    @staticmethod
    def box_overlap(x_left, x_right, sigma) -> NDArray[np.float64]:
        """Share of light spread evenly over box ``b'`` (``[x_left, x_right]``) and blurred
        by ``sigma[..., b']`` that lands in box ``b``: ``A[..., b, b']``
        (:func:`~sassi_bench.maths.normal.box_overlap`)."""
        return box_overlap(x_left, x_right, sigma)

    @staticmethod
    def pixel_spot(offset: ArrayLike, aperture_px: float, sigma_px: ArrayLike):
        """One SLM pixel's image (a box of ``aperture_px``) blurred by a PSF of
        ``sigma_px`` and integrated by a camera pixel, at ``offset`` px, with its slopes
        (:func:`~sassi_bench.maths.normal.pixel_spot`)."""
        return pixel_spot(offset, aperture_px, sigma_px)


#: The Gaussian profile of the blur forms so far.
GAUSSIAN = GaussianProfile()


class BlurModel(ABC):
    """The spot one SLM pixel makes on the spectral camera (before the camera pixel).

    Subclasses are the blur's forms (:data:`BLUR_FORMS`); see the module's note for what
    the object answers. Every form has a summation window (``window_sigmas``, the half
    width of a streak's rows in sigmas) and may state its own error between the lines it
    was fitted at (``relative_error``, a fraction; None when it states none).
    """

    def _check_pixel_and_error(self, where: str) -> None:
        """Check and normalise the fields every form has: ``pixel_variance_px2`` (>= 0)
        and ``relative_error`` (None or in [0, 1)); ``where`` names the entry in errors."""
        pixel = real(self.pixel_variance_px2, f"{where}.pixel_variance_px2")
        if pixel < 0:
            raise bad(f"{where}.pixel_variance_px2", f"must be >= 0, got {pixel!r}")
        object.__setattr__(self, "pixel_variance_px2", pixel)
        if self.relative_error is not None:
            error = real(self.relative_error, f"{where}.relative_error")
            if not 0 <= error < 1:
                raise bad(f"{where}.relative_error", f"must be in [0, 1), got {error!r}")
            object.__setattr__(self, "relative_error", error)

    window_sigmas: float
    relative_error: float | None
    pixel_variance_px2: float

    @property
    @abstractmethod
    def kind(self) -> str:
        """The manifest's ``models.blur.model`` of this model."""

    @abstractmethod
    def spot(self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike) -> Spot:
        """The spot at SLM pixels ``(u, v)`` and wavelengths (arrays broadcast together)."""

    @abstractmethod
    def sigma(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The widest spot at each wavelength, over the field and both directions (camera
        px): what a streak's footprint must reserve."""

    @abstractmethod
    def psf(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike, *, slm_pixel_variance_px2: float
    ) -> Spot:
        """The optics' PSF behind the spot, without the SLM pixel's image (whose variance,
        camera px², a form that does not hold it takes from its caller)."""

    @abstractmethod
    def to_manifest(self) -> dict[str, Any]:
        """The ``models.blur`` entry."""

    @classmethod
    @abstractmethod
    def from_entry(cls, entry: dict[str, Any]) -> BlurModel:
        """Build from a ``models.blur`` entry of this form (its ``model`` a name the form
        is registered under)."""

    @property
    def profile(self) -> GaussianProfile:
        """The spot's profile: its pixel-integrated shares."""
        return GAUSSIAN

    def window_half_width(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Half-width of the summation window, ``window_sigmas · sigma(λ)``, in rows."""
        return self.window_sigmas * self.sigma(wavelength_nm)


def blur_from_manifest(entry: Any) -> BlurModel:
    """The blur model of a ``models.blur`` entry, by its form (``model``).

    Examples
    --------
    >>> blur = blur_from_manifest({"model": "psf_quadratic", "coeffs": [0.5, 0.0, 2.0],
    ...     "lambda_ref_nm": 550.0, "lambda_scale_nm": 150.0, "window_sigmas": 3.0,
    ...     "pixel_variance_px2": 0.16})
    >>> type(blur).__name__, blur.kind
    ('QuadraticBlur', 'psf_quadratic')
    """
    where = "models.blur"
    entry = mapping(entry, where)
    kind = entry.get("model")
    if not isinstance(kind, str) or kind not in BLUR_FORMS:
        raise bad(
            f"{where}.model",
            f"is {kind!r}; this version knows {', '.join(repr(k) for k in BLUR_FORMS)}",
        )
    return BLUR_FORMS[kind].from_entry(dict(entry))
