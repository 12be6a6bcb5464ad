"""The calibration models a bundle holds, and how they are evaluated (the model contract).

This module is the single definition of the model content shared by the fitting code (which
builds these objects and publishes them) and by every consumer (which loads them). The
manifest's ``models`` section and the arrays it names are produced by
:meth:`CalibrationModels.to_manifest` and read back by :meth:`CalibrationModels.from_manifest`.

Coordinates: SLM pixel ``(u, v)`` = (column, row), camera pixel ``(x, y)``, wavelength ``λ`` in
nm; pixel centres at integer coordinates.

Dispersion (``models.dispersion``)
    ``{"glass", "sellmeier_b": [B1, B2, B3], "sellmeier_c": [C1, C2, C3] (µm²), "n_ref",
    "n_scale", "field_basis": "legendre2d", "field_degree": D, "slm_shape": [H, W],
    "x_coeffs": <array>, "lambda_ref_nm", "lambda_scale_nm", "y_coeffs": <array>}``.

    * refractive index ``n(λ) = sqrt(1 + Σ_i B_i λ² / (λ² − C_i))``, ``λ`` in µm;
    * spectral variables ``s_x = (n(λ) − n_ref) / n_scale`` and
      ``s_y = (λ − lambda_ref_nm) / lambda_scale_nm``;
    * field coordinates ``û = 2u / (W − 1) − 1``, ``v̂ = 2v / (H − 1) − 1`` (−1..1 over the SLM);
    * field basis: the products ``P_i(û) P_j(v̂)`` of Legendre polynomials for all
      ``i + j <= D``, ordered by total degree, then ``i`` descending
      (:func:`legendre2d_terms`);
    * arrays ``x_coeffs`` and ``y_coeffs`` of shape ``(K, n_terms)`` (``K = 3`` for the
      quadratic fit): ``x(u, v, λ) = Σ_k Σ_t x_coeffs[k, t] basis_t(û, v̂) s_x^k`` and
      ``y(u, v, λ) = Σ_k Σ_t y_coeffs[k, t] basis_t(û, v̂) s_y^k``.

Wavelength bins (``models.wavelength_bins``)
    Names of three arrays: ``bin_centres_nm`` ``(B,)``, ``bin_edges_nm`` ``(B + 1,)`` (strictly
    increasing, each centre inside its bin) and ``bin_resolution_nm`` ``(B,)``.

Blur (``models.blur``)
    ``{"model": "quadratic", "coeffs": [c0, c1, c2], "lambda_ref_nm", "lambda_scale_nm",
    "window_sigmas"}``: Gaussian ``sigma(λ) = c0 + c1 t + c2 t²`` camera px with
    ``t = (λ − lambda_ref_nm) / lambda_scale_nm``; the half-width of the summation window is
    ``window_sigmas · sigma(λ)`` rows. ``sigma`` must be positive over the bins.

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

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.polynomial import legendre, polynomial
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle.errors import BundleSchemaError
from sassi_bench.bundle.jsonio import freeze, thaw, to_jsonable
from sassi_bench.errors import step_error
from sassi_bench.optics.glass import sellmeier_index

__all__ = [
    "BlurModel",
    "CalibrationModels",
    "DispersionModel",
    "WavelengthBins",
    "field_coordinates",
    "legendre2d_design",
    "legendre2d_terms",
    "sellmeier_index",
]

#: The field basis this version of the contract defines.
FIELD_BASIS = "legendre2d"
MAX_FIELD_DEGREE = 12

_FIX = "the fitting code must produce models that follow sassi_bench.bundle.models"
#: Field points (û, v̂) where the dispersion is checked: corners, edge midpoints, centre.
_CHECK_FIELD = np.array([(a, b) for a in (-1.0, 0.0, 1.0) for b in (-1.0, 0.0, 1.0)])
_CHECK_SAMPLES = 257


def _bad(where: str, cause: str, fix: str = _FIX) -> BundleSchemaError:
    return BundleSchemaError(step_error(where, cause, fix))


# ---------------------------------------------------------------------------------------------
# Evaluation helpers (also imported by the fitting code)
# ---------------------------------------------------------------------------------------------


def legendre2d_terms(degree: int) -> tuple[tuple[int, int], ...]:
    """Exponent pairs ``(i, j)`` of the 2D Legendre basis ``P_i(û) P_j(v̂)``, ``i + j <= degree``.

    Ordered by total degree ``i + j``, then by ``i`` descending.

    Parameters
    ----------
    degree
        Maximum total degree ``D >= 0``.

    Returns
    -------
    tuple of (int, int)
        ``(D + 1)(D + 2) / 2`` pairs.

    Examples
    --------
    >>> legendre2d_terms(2)
    ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    """
    if isinstance(degree, bool) or not isinstance(degree, numbers.Integral) or degree < 0:
        raise ValueError(f"legendre2d degree must be an integer >= 0, got {degree!r}")
    return tuple((i, total - i) for total in range(int(degree) + 1) for i in range(total, -1, -1))


def _horner(s: ArrayLike, coeffs: NDArray[np.float64]) -> NDArray[np.float64]:
    """``sum_k coeffs[k] * s**k`` (``coeffs[k]`` broadcasting with ``s``), in place.

    numpy's ``polyval`` allocates a new array at every step; on the streak geometry of a
    prototype-scale frame (4320 pixels x 137 wavelengths) this is twice as fast.

    Examples
    --------
    >>> _horner(np.array([2.0]), np.array([1.0, 0.0, 3.0])).tolist()
    [13.0]
    """
    s = np.asarray(s, dtype=np.float64)
    out = np.empty(np.broadcast_shapes(s.shape, coeffs.shape[1:]))
    out[...] = coeffs[-1]
    for c in coeffs[-2::-1]:
        out *= s
        out += c
    return out


def legendre2d_design(u_hat: ArrayLike, v_hat: ArrayLike, degree: int) -> NDArray[np.float64]:
    """Design matrix of the 2D Legendre field basis.

    Parameters
    ----------
    u_hat, v_hat
        Normalised field coordinates (−1..1 over the SLM); broadcast together.
    degree
        Maximum total degree ``D``.

    Returns
    -------
    ndarray
        Shape ``broadcast_shape + (n_terms,)``; column ``t`` is ``P_i(û) P_j(v̂)`` for the
        ``t``-th pair of :func:`legendre2d_terms`.

    Examples
    --------
    >>> legendre2d_design(0.5, -1.0, 1)  # P0 P0, P1(û) P0, P0 P1(v̂)
    array([ 1. ,  0.5, -1. ])
    """
    terms = legendre2d_terms(degree)
    u, v = np.broadcast_arrays(
        np.asarray(u_hat, dtype=np.float64), np.asarray(v_hat, dtype=np.float64)
    )
    # legvander promotes 0-d input to 1-d; restore the broadcast shape.
    pu = legendre.legvander(u, degree).reshape((*u.shape, degree + 1))
    pv = legendre.legvander(v, degree).reshape((*v.shape, degree + 1))
    i_idx = np.array([i for i, _ in terms])
    j_idx = np.array([j for _, j in terms])
    return pu[..., i_idx] * pv[..., j_idx]


def field_coordinates(
    u: ArrayLike, v: ArrayLike, slm_shape: tuple[int, int]
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """SLM pixel ``(u, v)`` -> normalised field coordinates ``(û, v̂)`` in −1..1.

    Examples
    --------
    >>> field_coordinates([0, 639], [0, 399], (400, 640))
    (array([-1.,  1.]), array([-1.,  1.]))
    """
    height, width = slm_shape
    u_hat = 2.0 * np.asarray(u, dtype=np.float64) / (width - 1) - 1.0
    v_hat = 2.0 * np.asarray(v, dtype=np.float64) / (height - 1) - 1.0
    return u_hat, v_hat


# ---------------------------------------------------------------------------------------------
# Value checks
# ---------------------------------------------------------------------------------------------


def _real(value: Any, where: str, *, positive: bool = False) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise _bad(where, f"must be a number, got {type(value).__name__}")
    try:
        out = float(value)
    except OverflowError:
        out = math.inf
    if not math.isfinite(out):
        raise _bad(where, f"must be finite, got {out}")
    if positive and out <= 0:
        raise _bad(where, f"must be > 0, got {out}")
    return out


def _reals(value: Any, count: int, where: str) -> tuple[float, ...]:
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__"):
        raise _bad(where, f"must be a list of {count} numbers")
    items = list(value)
    if len(items) != count:
        raise _bad(where, f"must hold {count} numbers, got {len(items)}")
    return tuple(_real(item, f"{where}[{i}]") for i, item in enumerate(items))


def _int(value: Any, where: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise _bad(where, f"must be an integer, got {type(value).__name__}")
    if not low <= int(value) <= high:
        raise _bad(where, f"must be between {low} and {high}, got {value}")
    return int(value)


def _frozen_array(value: Any, where: str, ndim: int) -> NDArray[np.float64]:
    """Read-only float64 copy of a finite real array with ``ndim`` dimensions."""
    try:
        array = np.asarray(value)
    except (ValueError, TypeError, OverflowError) as exc:
        raise _bad(where, f"is not a numeric array ({exc})") from exc
    if array.dtype.kind not in "iuf":
        raise _bad(where, f"must be a real numeric array, got dtype {array.dtype}")
    if array.ndim != ndim:
        raise _bad(where, f"must have {ndim} dimension(s), got shape {array.shape}")
    out = np.array(array, dtype=np.float64, copy=True)
    if not np.all(np.isfinite(out)):
        raise _bad(where, "holds NaN or infinite values")
    out.flags.writeable = False
    return out


def _array_ref(entry: Mapping[str, Any], key: str, arrays: Mapping[str, Any], where: str) -> Any:
    name = entry.get(key)
    if not isinstance(name, str):
        raise _bad(f"{where}.{key}", "must name an array")
    if name not in arrays:
        raise _bad(
            f"{where}.{key}",
            f"names array {name!r}, which the bundle does not hold",
            "publish the bundle again; every array a model names must be saved with it",
        )
    return arrays[name]


def _mapping(value: Any, where: str) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise _bad(where, f"must be an object, got {type(value).__name__}")
    return value


# ---------------------------------------------------------------------------------------------
# Models
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class DispersionModel:
    """Where each SLM pixel's light of each wavelength lands on the camera.

    See the module docstring for the formulas. Arrays are stored as read-only float64 copies.

    Parameters
    ----------
    glass
        Prism glass name (informative; the Sellmeier coefficients are what is evaluated).
    sellmeier_b, sellmeier_c
        Sellmeier ``B_i`` and ``C_i`` (µm²).
    n_ref, n_scale
        Normalisation of the index: ``s_x = (n − n_ref) / n_scale``; ``n_scale > 0``.
    lambda_ref_nm, lambda_scale_nm
        Normalisation of the wavelength: ``s_y = (λ − ref) / scale``; ``scale > 0``.
    slm_shape
        SLM ``(H, W)`` in pixels, which defines the field coordinates.
    field_degree
        Total degree ``D`` of the 2D Legendre field basis.
    x_coeffs, y_coeffs
        ``(K, n_terms)`` coefficient arrays (``K = 3`` for the quadratic fit).

    Examples
    --------
    >>> import numpy as np
    >>> x = np.zeros((3, 3)); x[0, 0] = 1000.0; x[1, 0] = -34.0
    >>> y = np.zeros((3, 3)); y[0, 0] = 500.0
    >>> model = DispersionModel("N-BK7", (1.03961212, 0.231792344, 1.01046945),
    ...                         (0.00600069867, 0.0200179144, 103.560653), 1.52, 0.005,
    ...                         550.0, 150.0, (400, 640), 1, x, y)
    >>> xs, ys = model.evaluate(319.5, 199.5, [400.0, 700.0])
    >>> bool(xs[1] > xs[0]), ys.tolist()
    (True, [500.0, 500.0])
    """

    glass: str
    sellmeier_b: tuple[float, float, float]
    sellmeier_c: tuple[float, float, float]
    n_ref: float
    n_scale: float
    lambda_ref_nm: float
    lambda_scale_nm: float
    slm_shape: tuple[int, int]
    field_degree: int
    x_coeffs: NDArray[np.float64]
    y_coeffs: NDArray[np.float64]

    def __post_init__(self) -> None:
        where = "models.dispersion"
        if not isinstance(self.glass, str) or not self.glass:
            raise _bad(f"{where}.glass", "must be a non-empty string")
        b = _reals(self.sellmeier_b, 3, f"{where}.sellmeier_b")
        c = _reals(self.sellmeier_c, 3, f"{where}.sellmeier_c")
        shape = tuple(
            _int(s, f"{where}.slm_shape", 2, 10**6)
            for s in _seq(self.slm_shape, 2, f"{where}.slm_shape")
        )
        degree = _int(self.field_degree, f"{where}.field_degree", 0, MAX_FIELD_DEGREE)
        n_terms = len(legendre2d_terms(degree))
        coeffs = {}
        for key in ("x_coeffs", "y_coeffs"):
            array = _frozen_array(getattr(self, key), f"{where}.{key}", 2)
            if array.shape[0] < 1 or array.shape[1] != n_terms:
                raise _bad(
                    f"{where}.{key}",
                    f"has shape {array.shape}, expected (K, {n_terms}) for field_degree {degree}",
                )
            coeffs[key] = array
        values = {
            "sellmeier_b": b,
            "sellmeier_c": c,
            "n_ref": _real(self.n_ref, f"{where}.n_ref"),
            "n_scale": _real(self.n_scale, f"{where}.n_scale", positive=True),
            "lambda_ref_nm": _real(self.lambda_ref_nm, f"{where}.lambda_ref_nm"),
            "lambda_scale_nm": _real(
                self.lambda_scale_nm, f"{where}.lambda_scale_nm", positive=True
            ),
            "slm_shape": shape,
            "field_degree": degree,
            **coeffs,
        }
        for key, value in values.items():
            object.__setattr__(self, key, value)

    def index(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Prism refractive index ``n(λ)`` from the stored Sellmeier coefficients."""
        return sellmeier_index(wavelength_nm, self.sellmeier_b, self.sellmeier_c)

    def spectral_x(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """``s_x = (n(λ) − n_ref) / n_scale``."""
        return (self.index(wavelength_nm) - self.n_ref) / self.n_scale

    def spectral_y(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """``s_y = (λ − lambda_ref_nm) / lambda_scale_nm``."""
        return (np.asarray(wavelength_nm, dtype=np.float64) - self.lambda_ref_nm) / (
            self.lambda_scale_nm
        )

    def evaluate(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera ``(x, y)`` of SLM pixel ``(u, v)`` at ``wavelength_nm``.

        ``u``, ``v`` and ``wavelength_nm`` broadcast together (numpy rules); the field basis is
        evaluated only on the broadcast shape of ``(u, v)``, so a grid of field points against a
        vector of wavelengths (``u[:, None]``, ``wavelength_nm[None, :]``) is cheap.
        """
        cx, cy = self.field_coefficients(u, v)
        return _horner(self.spectral_x(wavelength_nm), cx), _horner(
            self.spectral_y(wavelength_nm), cy
        )

    def field_coefficients(
        self, u: ArrayLike, v: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The polynomials of SLM pixel ``(u, v)``: ``x = sum_k cx[k] s_x**k``, likewise y.

        Returns
        -------
        cx, cy : ndarray
            ``(K, *broadcast shape of u and v)``; power ``k`` on the first axis.

        Examples
        --------
        >>> x = np.zeros((3, 1)); x[:, 0] = [100.0, -3.0, 0.5]
        >>> model = DispersionModel("N-BK7", (1.03961212, 0.231792344, 1.01046945),
        ...                         (0.00600069867, 0.0200179144, 103.560653), 1.52, 0.005,
        ...                         550.0, 150.0, (400, 640), 0, x, np.zeros((3, 1)))
        >>> cx, cy = model.field_coefficients([0, 639], [0, 399])
        >>> cx.shape, cx[:, 1].tolist()
        ((3, 2), [100.0, -3.0, 0.5])
        """
        u_hat, v_hat = field_coordinates(u, v, self.slm_shape)
        design = legendre2d_design(u_hat, v_hat, self.field_degree)
        # One 2-D product: a stacked matmul over (N, 1, terms) would do N tiny products.
        terms = design.reshape(-1, design.shape[-1])
        cx = (terms @ self.x_coeffs.T).reshape(*design.shape[:-1], self.x_coeffs.shape[0])
        cy = (terms @ self.y_coeffs.T).reshape(*design.shape[:-1], self.y_coeffs.shape[0])
        return np.moveaxis(cx, -1, 0), np.moveaxis(cy, -1, 0)

    def to_manifest(
        self, x_name: str = "dispersion_x_coeffs", y_name: str = "dispersion_y_coeffs"
    ) -> tuple[dict[str, Any], dict[str, NDArray[np.float64]]]:
        """The ``models.dispersion`` entry and the arrays it names."""
        entry = {
            "glass": self.glass,
            "sellmeier_b": list(self.sellmeier_b),
            "sellmeier_c": list(self.sellmeier_c),
            "n_ref": self.n_ref,
            "n_scale": self.n_scale,
            "field_basis": FIELD_BASIS,
            "field_degree": self.field_degree,
            "slm_shape": list(self.slm_shape),
            "x_coeffs": x_name,
            "lambda_ref_nm": self.lambda_ref_nm,
            "lambda_scale_nm": self.lambda_scale_nm,
            "y_coeffs": y_name,
        }
        return entry, {x_name: self.x_coeffs, y_name: self.y_coeffs}

    @classmethod
    def from_manifest(cls, entry: Any, arrays: Mapping[str, Any]) -> DispersionModel:
        """Build from a ``models.dispersion`` entry and the bundle's arrays."""
        where = "models.dispersion"
        entry = _mapping(entry, where)
        basis = entry.get("field_basis")
        if basis != FIELD_BASIS:
            raise _bad(f"{where}.field_basis", f"is {basis!r}; this version knows {FIELD_BASIS!r}")
        missing = [key for key in _DISPERSION_KEYS if key not in entry]
        if missing:
            raise _bad(where, f"lacks {', '.join(missing)}")
        return cls(
            glass=entry["glass"],
            sellmeier_b=entry["sellmeier_b"],
            sellmeier_c=entry["sellmeier_c"],
            n_ref=entry["n_ref"],
            n_scale=entry["n_scale"],
            lambda_ref_nm=entry["lambda_ref_nm"],
            lambda_scale_nm=entry["lambda_scale_nm"],
            slm_shape=entry["slm_shape"],
            field_degree=entry["field_degree"],
            x_coeffs=_array_ref(entry, "x_coeffs", arrays, where),
            y_coeffs=_array_ref(entry, "y_coeffs", arrays, where),
        )


_DISPERSION_KEYS = (
    "glass",
    "sellmeier_b",
    "sellmeier_c",
    "n_ref",
    "n_scale",
    "field_degree",
    "slm_shape",
    "x_coeffs",
    "lambda_ref_nm",
    "lambda_scale_nm",
    "y_coeffs",
)


def _seq(value: Any, count: int, where: str) -> list[Any]:
    if isinstance(value, (str, bytes, Mapping)) or not hasattr(value, "__len__"):
        raise _bad(where, f"must be a list of {count} values")
    items = list(value)
    if len(items) != count:
        raise _bad(where, f"must hold {count} values, got {len(items)}")
    return items


@dataclass(frozen=True, eq=False)
class WavelengthBins:
    """The spectral bins of a streak.

    Parameters
    ----------
    centres_nm
        ``(B,)`` bin centres.
    edges_nm
        ``(B + 1,)`` strictly increasing edges; centre ``i`` lies in ``[edges[i], edges[i+1]]``.
    resolution_nm
        ``(B,)`` spectral resolution (positive) of each bin.

    Examples
    --------
    >>> bins = WavelengthBins([450.0, 550.0], [400.0, 500.0, 600.0], [100.0, 100.0])
    >>> bins.count
    2
    """

    centres_nm: NDArray[np.float64]
    edges_nm: NDArray[np.float64]
    resolution_nm: NDArray[np.float64]

    def __post_init__(self) -> None:
        where = "models.wavelength_bins"
        centres = _frozen_array(self.centres_nm, f"{where}.bin_centres_nm", 1)
        edges = _frozen_array(self.edges_nm, f"{where}.bin_edges_nm", 1)
        resolution = _frozen_array(self.resolution_nm, f"{where}.bin_resolution_nm", 1)
        if centres.size < 1:
            raise _bad(f"{where}.bin_centres_nm", "is empty")
        if edges.shape != (centres.size + 1,):
            raise _bad(
                f"{where}.bin_edges_nm",
                f"has shape {edges.shape}, expected ({centres.size + 1},) for {centres.size} bins",
            )
        if resolution.shape != centres.shape:
            raise _bad(
                f"{where}.bin_resolution_nm",
                f"has shape {resolution.shape}, expected {centres.shape}",
            )
        if np.any(np.diff(edges) <= 0):
            raise _bad(f"{where}.bin_edges_nm", "must be strictly increasing")
        if edges[0] <= 0:
            raise _bad(f"{where}.bin_edges_nm", "must be positive wavelengths in nm")
        if np.any(centres < edges[:-1]) or np.any(centres > edges[1:]):
            raise _bad(f"{where}.bin_centres_nm", "must each lie between their bin's edges")
        if np.any(resolution <= 0):
            raise _bad(f"{where}.bin_resolution_nm", "must be > 0")
        object.__setattr__(self, "centres_nm", centres)
        object.__setattr__(self, "edges_nm", edges)
        object.__setattr__(self, "resolution_nm", resolution)

    @property
    def count(self) -> int:
        """Number of bins ``B``."""
        return int(self.centres_nm.size)

    def to_manifest(self) -> tuple[dict[str, str], dict[str, NDArray[np.float64]]]:
        """The ``models.wavelength_bins`` entry and the arrays it names."""
        entry = {
            "bin_centres_nm": "bin_centres_nm",
            "bin_edges_nm": "bin_edges_nm",
            "bin_resolution_nm": "bin_resolution_nm",
        }
        arrays = {
            "bin_centres_nm": self.centres_nm,
            "bin_edges_nm": self.edges_nm,
            "bin_resolution_nm": self.resolution_nm,
        }
        return entry, arrays

    @classmethod
    def from_manifest(cls, entry: Any, arrays: Mapping[str, Any]) -> WavelengthBins:
        """Build from a ``models.wavelength_bins`` entry and the bundle's arrays."""
        where = "models.wavelength_bins"
        entry = _mapping(entry, where)
        return cls(
            centres_nm=_array_ref(entry, "bin_centres_nm", arrays, where),
            edges_nm=_array_ref(entry, "bin_edges_nm", arrays, where),
            resolution_nm=_array_ref(entry, "bin_resolution_nm", arrays, where),
        )


@dataclass(frozen=True, eq=False)
class BlurModel:
    """Wavelength-dependent Gaussian blur: ``sigma(λ) = c0 + c1 t + c2 t²``.

    Parameters
    ----------
    coeffs
        ``(c0, c1, c2)`` in camera px.
    lambda_ref_nm, lambda_scale_nm
        ``t = (λ − lambda_ref_nm) / lambda_scale_nm``.
    window_sigmas
        Half-width of the summation window in units of sigma.

    Examples
    --------
    >>> blur = BlurModel((1.0, 0.0, 3.0), 520.0, 115.0, 2.5)
    >>> blur.sigma([405.0, 520.0, 635.0]).round(3).tolist()
    [4.0, 1.0, 4.0]
    """

    coeffs: tuple[float, float, float]
    lambda_ref_nm: float
    lambda_scale_nm: float
    window_sigmas: float

    def __post_init__(self) -> None:
        where = "models.blur"
        object.__setattr__(self, "coeffs", _reals(self.coeffs, 3, f"{where}.coeffs"))
        object.__setattr__(
            self, "lambda_ref_nm", _real(self.lambda_ref_nm, f"{where}.lambda_ref_nm")
        )
        object.__setattr__(
            self,
            "lambda_scale_nm",
            _real(self.lambda_scale_nm, f"{where}.lambda_scale_nm", positive=True),
        )
        object.__setattr__(
            self,
            "window_sigmas",
            _real(self.window_sigmas, f"{where}.window_sigmas", positive=True),
        )

    def sigma(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Gaussian sigma in camera px at ``wavelength_nm`` (vectorised)."""
        t = (np.asarray(wavelength_nm, dtype=np.float64) - self.lambda_ref_nm) / (
            self.lambda_scale_nm
        )
        return np.asarray(polynomial.polyval(t, self.coeffs), dtype=np.float64)

    def window_half_width(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Half-width of the summation window, ``window_sigmas · sigma(λ)``, in rows."""
        return self.window_sigmas * self.sigma(wavelength_nm)

    def to_manifest(self) -> dict[str, Any]:
        """The ``models.blur`` entry."""
        return {
            "model": "quadratic",
            "coeffs": list(self.coeffs),
            "lambda_ref_nm": self.lambda_ref_nm,
            "lambda_scale_nm": self.lambda_scale_nm,
            "window_sigmas": self.window_sigmas,
        }

    @classmethod
    def from_manifest(cls, entry: Any) -> BlurModel:
        """Build from a ``models.blur`` entry."""
        where = "models.blur"
        entry = _mapping(entry, where)
        if entry.get("model") != "quadratic":
            raise _bad(
                f"{where}.model", f"is {entry.get('model')!r}; this version knows 'quadratic'"
            )
        missing = [
            key
            for key in ("coeffs", "lambda_ref_nm", "lambda_scale_nm", "window_sigmas")
            if key not in entry
        ]
        if missing:
            raise _bad(where, f"lacks {', '.join(missing)}")
        return cls(
            coeffs=entry["coeffs"],
            lambda_ref_nm=entry["lambda_ref_nm"],
            lambda_scale_nm=entry["lambda_scale_nm"],
            window_sigmas=entry["window_sigmas"],
        )


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
    >>> models = CalibrationModels(dispersion, bins, blur)  # doctest: +SKIP
    >>> entry, arrays = models.to_manifest()  # doctest: +SKIP
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
                raise _bad(f"models.{name}", f"must be a {kind.__name__}")
        bins = self.bins
        if self.guide_to_slm is not None:
            matrix = _frozen_array(self.guide_to_slm, "models.guide_homography", 2)
            if matrix.shape != (3, 3):
                raise _bad("models.guide_homography", f"must be 3x3, got {matrix.shape}")
            if not abs(np.linalg.det(matrix)) > 1e-12 * max(1.0, float(np.abs(matrix).max()) ** 3):
                raise _bad("models.guide_homography", "is singular")
            object.__setattr__(self, "guide_to_slm", matrix)
        info = to_jsonable(
            dict(_mapping(self.guide_info, "models.guide_homography")),
            "models.guide_homography",
            "models",
        )
        if "array" in info:
            raise _bad("models.guide_homography", "info must not hold the key 'array'")
        if "rms_px" in info:
            _real(info["rms_px"], "models.guide_homography.rms_px")
        object.__setattr__(self, "guide_info", freeze(info))
        if self.offset is not None:
            offset = to_jsonable(
                dict(_mapping(self.offset, "models.offset")), "models.offset", "models"
            )
            if not isinstance(offset.get("method"), str) or not offset["method"]:
                raise _bad("models.offset.method", "must be a non-empty string")
            object.__setattr__(self, "offset", freeze(offset))
        if self.response is not None:
            response = _frozen_array(self.response, "models.response", 1)
            if response.shape != (bins.count,):
                raise _bad(
                    "models.response", f"has shape {response.shape}, expected ({bins.count},)"
                )
            if np.any(response < 0):
                raise _bad("models.response", "must be >= 0")
            object.__setattr__(self, "response", response)
        self._check_over_range()

    def _check_over_range(self) -> None:
        """Sample the models over the bins' range: sigma > 0, valid index, monotonic streaks."""
        lo, hi = float(self.bins.edges_nm[0]), float(self.bins.edges_nm[-1])
        lam = np.union1d(np.linspace(lo, hi, _CHECK_SAMPLES), self.bins.edges_nm)
        with np.errstate(all="ignore"):
            sigma = self.blur.sigma(lam)
            if not np.all(np.isfinite(sigma) & (sigma > 0)):
                raise _bad("models.blur", f"sigma must be > 0 over the bins ({lo:g}-{hi:g} nm)")
            n = self.dispersion.index(lam)
            if not np.all(np.isfinite(n) & (n > 1)):
                raise _bad(
                    "models.dispersion.sellmeier_b",
                    f"give no valid refractive index over the bins ({lo:g}-{hi:g} nm)",
                )
            height, width = self.dispersion.slm_shape
            u = (_CHECK_FIELD[:, 0] + 1.0) * (width - 1) / 2.0
            v = (_CHECK_FIELD[:, 1] + 1.0) * (height - 1) / 2.0
            x, y = self.dispersion.evaluate(u[:, None], v[:, None], lam[None, :])
            if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
                raise _bad("models.dispersion", "is not finite over the field and the bins")
            steps = np.diff(x, axis=1)
            if not (np.all(steps > 0) or np.all(steps < 0)):
                raise _bad(
                    "models.dispersion.x_coeffs",
                    "give streaks whose camera x is not monotonic in wavelength over the field "
                    f"and the bins ({lo:g}-{hi:g} nm)",
                )

    def to_manifest(self) -> tuple[dict[str, Any], dict[str, NDArray[np.float64]]]:
        """The manifest's ``models`` section and the arrays it names.

        Examples
        --------
        >>> section, arrays = models.to_manifest()  # doctest: +SKIP
        >>> sorted(section)  # doctest: +SKIP
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
        section = _mapping(section, "models")
        guide = section.get("guide_homography")
        guide_matrix = None
        guide_info: dict[str, Any] = {}
        if guide is not None:
            guide = _mapping(guide, "models.guide_homography")
            guide_matrix = _array_ref(guide, "array", arrays, "models.guide_homography")
            guide_info = {key: value for key, value in guide.items() if key != "array"}
        response = section.get("response")
        if response is not None:
            response = _array_ref(
                _mapping(response, "models.response"), "array", arrays, "models.response"
            )
        offset = section.get("offset")
        if offset is not None:
            offset = _mapping(offset, "models.offset")
        return cls(
            dispersion=DispersionModel.from_manifest(section.get("dispersion"), arrays),
            bins=WavelengthBins.from_manifest(section.get("wavelength_bins"), arrays),
            blur=BlurModel.from_manifest(section.get("blur")),
            guide_to_slm=guide_matrix,
            guide_info=thaw(guide_info),
            offset=thaw(offset) if offset is not None else None,
            response=response,
        )
