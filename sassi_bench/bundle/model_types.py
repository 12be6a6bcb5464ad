"""Two of the three required models of the contract: dispersion and wavelength bins (the
blur is :mod:`sassi_bench.bundle.blur`).

Each model checks its values when it is built (:mod:`sassi_bench.bundle.model_checks`),
evaluates its formula, and converts to and from its entry of the manifest's ``models``
section plus the arrays that entry names. The formulas and the manifest entries are
defined in :mod:`sassi_bench.bundle.models`; the field basis in
:mod:`sassi_bench.maths.legendre`.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle.model_checks import (
    array_ref,
    bad,
    frozen_array,
    integer,
    mapping,
    real,
    reals,
    sequence,
)
from sassi_bench.maths.legendre import (
    field_coordinates,
    horner,
    legendre2d_design,
    legendre2d_terms,
)
from sassi_bench.optics.glass import sellmeier_index

__all__ = ["FIELD_BASIS", "MAX_FIELD_DEGREE", "DispersionModel", "WavelengthBins"]

#: The field basis this version of the contract defines.
FIELD_BASIS = "legendre2d"
MAX_FIELD_DEGREE = 12


@dataclass(frozen=True, eq=False)
class DispersionModel:
    """Where each SLM pixel's light of each wavelength lands on the camera.

    The formulas are those of :mod:`sassi_bench.bundle.models`. Arrays are stored as read-only
    float64 copies.

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
        ``(K, n_terms)`` coefficient arrays (``K = 3`` for the quadratic fit): the column in
        ``s_x``, the row in ``s_y`` (the paper's form).
    y_index_coeffs
        The row's ``(K, n_terms)`` coefficients in ``s_x`` instead (schema 1.1), or None.
        When given, rows are evaluated from them; ``y_coeffs`` stays in the bundle for
        readers of schema 1.0.

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
    y_index_coeffs: NDArray[np.float64] | None = None

    def __post_init__(self) -> None:
        where = "models.dispersion"
        if not isinstance(self.glass, str) or not self.glass:
            raise bad(f"{where}.glass", "must be a non-empty string")
        b = reals(self.sellmeier_b, 3, f"{where}.sellmeier_b")
        c = reals(self.sellmeier_c, 3, f"{where}.sellmeier_c")
        shape = tuple(
            integer(s, f"{where}.slm_shape", 2, 10**6)
            for s in sequence(self.slm_shape, 2, f"{where}.slm_shape")
        )
        degree = integer(self.field_degree, f"{where}.field_degree", 0, MAX_FIELD_DEGREE)
        n_terms = len(legendre2d_terms(degree))
        coeffs = {}
        keys = ("x_coeffs", "y_coeffs")
        if self.y_index_coeffs is not None:
            keys += ("y_index_coeffs",)
        for key in keys:
            coeffs[key] = frozen_array(
                getattr(self, key),
                f"{where}.{key}",
                ("K", n_terms),
                expected_for=f"field_degree {degree}",
                allow_empty=False,
            )
        values = {
            "sellmeier_b": b,
            "sellmeier_c": c,
            "n_ref": real(self.n_ref, f"{where}.n_ref"),
            "n_scale": real(self.n_scale, f"{where}.n_scale", positive=True),
            "lambda_ref_nm": real(self.lambda_ref_nm, f"{where}.lambda_ref_nm"),
            "lambda_scale_nm": real(
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

    @property
    def row_in_index(self) -> bool:
        """Whether rows are a polynomial in ``s_x`` (``y_index_coeffs``) rather than ``s_y``."""
        return self.y_index_coeffs is not None

    @property
    def row_coeffs(self) -> NDArray[np.float64]:
        """The row's coefficients in :meth:`row_coordinate`: ``y_index_coeffs`` if given."""
        return self.y_coeffs if self.y_index_coeffs is None else self.y_index_coeffs

    def row_coordinate(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The spectral coordinate the row is a polynomial in: ``s_x`` or ``s_y``."""
        if self.row_in_index:
            return self.spectral_x(wavelength_nm)
        return self.spectral_y(wavelength_nm)

    def evaluate(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera ``(x, y)`` of SLM pixel ``(u, v)`` at ``wavelength_nm``.

        ``u``, ``v`` and ``wavelength_nm`` broadcast together (numpy rules); the field basis is
        evaluated only on the broadcast shape of ``(u, v)``, so a grid of field points against a
        vector of wavelengths (``u[:, None]``, ``wavelength_nm[None, :]``) is cheap.
        """
        cx, cy = self.field_coefficients(u, v)
        return horner(self.spectral_x(wavelength_nm), cx), horner(
            self.row_coordinate(wavelength_nm), cy
        )

    def field_coefficients(
        self, u: ArrayLike, v: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The polynomials of SLM pixel ``(u, v)``: ``x = sum_k cx[k] s_x**k`` and
        ``y = sum_k cy[k] s**k`` in the :meth:`row_coordinate` ``s``.

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
        row = self.row_coeffs
        cy = (terms @ row.T).reshape(*design.shape[:-1], row.shape[0])
        return np.moveaxis(cx, -1, 0), np.moveaxis(cy, -1, 0)

    def to_manifest(
        self,
        x_name: str = "dispersion_x_coeffs",
        y_name: str = "dispersion_y_coeffs",
        y_index_name: str = "dispersion_y_index_coeffs",
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
        arrays = {x_name: self.x_coeffs, y_name: self.y_coeffs}
        if self.y_index_coeffs is not None:
            entry["y_index_coeffs"] = y_index_name
            arrays[y_index_name] = self.y_index_coeffs
        return entry, arrays

    @classmethod
    def from_manifest(cls, entry: Any, arrays: Mapping[str, Any]) -> DispersionModel:
        """Build from a ``models.dispersion`` entry and the bundle's arrays."""
        where = "models.dispersion"
        entry = mapping(entry, where)
        basis = entry.get("field_basis")
        if basis != FIELD_BASIS:
            raise bad(f"{where}.field_basis", f"is {basis!r}; this version knows {FIELD_BASIS!r}")
        missing = [key for key in _DISPERSION_KEYS if key not in entry]
        if missing:
            raise bad(where, f"lacks {', '.join(missing)}")
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
            x_coeffs=array_ref(entry, "x_coeffs", arrays, where),
            y_coeffs=array_ref(entry, "y_coeffs", arrays, where),
            y_index_coeffs=(
                array_ref(entry, "y_index_coeffs", arrays, where)
                if "y_index_coeffs" in entry
                else None
            ),
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
        centres = frozen_array(
            self.centres_nm, f"{where}.bin_centres_nm", ("B",), allow_empty=False
        )
        count = f"{centres.size} bins"
        edges = frozen_array(
            self.edges_nm, f"{where}.bin_edges_nm", (centres.size + 1,), expected_for=count
        )
        resolution = frozen_array(
            self.resolution_nm, f"{where}.bin_resolution_nm", centres.shape, expected_for=count
        )
        if np.any(np.diff(edges) <= 0):
            raise bad(f"{where}.bin_edges_nm", "must be strictly increasing")
        if edges[0] <= 0:
            raise bad(f"{where}.bin_edges_nm", "must be positive wavelengths in nm")
        if np.any(centres < edges[:-1]) or np.any(centres > edges[1:]):
            raise bad(f"{where}.bin_centres_nm", "must each lie between their bin's edges")
        if np.any(resolution <= 0):
            raise bad(f"{where}.bin_resolution_nm", "must be > 0")
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
        entry = mapping(entry, where)
        return cls(
            centres_nm=array_ref(entry, "bin_centres_nm", arrays, where),
            edges_nm=array_ref(entry, "bin_edges_nm", arrays, where),
            resolution_nm=array_ref(entry, "bin_resolution_nm", arrays, where),
        )
