"""Refractive index of prism glasses from their Sellmeier coefficients.

Coefficients are the three-term Sellmeier form used by glass makers,

    n^2(λ) - 1 = Σ_i B_i λ^2 / (λ^2 - C_i),   λ in µm, C_i in µm^2,

taken from the SCHOTT optical glass catalog (data sheets, 22 °C, 1013 hPa) as
published in the manufacturer's zemax catalog file ``SCHOTT.AGF``. ``nd`` and ``vd``
are the catalog's own rounded values, kept so tests can check the coefficients.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError, did_you_mean, step_error

__all__ = ["GLASSES", "Glass", "get_glass", "refractive_index", "sellmeier_index"]

#: Fraunhofer lines of the catalogue's nd and vd (helium d, hydrogen F and C), nm.
D_LINE_NM, F_LINE_NM, C_LINE_NM = 587.5618, 486.1327, 656.2725


def sellmeier_index(wavelength_nm: ArrayLike, b: ArrayLike, c: ArrayLike) -> NDArray[np.float64]:
    """Refractive index ``sqrt(1 + sum_i B_i lam^2 / (lam^2 - C_i))``, lam in µm.

    Examples
    --------
    >>> b = [1.03961212, 0.231792344, 1.01046945]  # N-BK7
    >>> c = [0.00600069867, 0.0200179144, 103.560653]
    >>> round(float(sellmeier_index(587.5618, b, c)), 4)
    1.5168
    """
    lam2 = (np.asarray(wavelength_nm, dtype=np.float64) * 1e-3)[..., None] ** 2
    terms = np.asarray(b, dtype=np.float64) * lam2 / (lam2 - np.asarray(c, dtype=np.float64))
    with np.errstate(invalid="ignore"):
        return np.sqrt(1.0 + terms.sum(axis=-1))


@dataclass(frozen=True)
class Glass:
    """An optical glass described by its Sellmeier coefficients.

    Parameters
    ----------
    name
        Catalog name, e.g. ``"N-SF11"``.
    b, c
        The three Sellmeier ``B_i`` (dimensionless) and ``C_i`` (µm²).
    nd, vd
        Catalog refractive index at the helium d line (587.5618 nm) and Abbe number.

    Examples
    --------
    >>> glass = get_glass("N-BK7")
    >>> round(float(glass.index(587.5618)), 5)
    1.5168
    """

    name: str
    b: tuple[float, float, float]
    c: tuple[float, float, float]
    nd: float
    vd: float

    def index(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Refractive index at ``wavelength_nm`` (vectorised, float64)."""
        return sellmeier_index(wavelength_nm, self.b, self.c)

    @classmethod
    def from_sellmeier(cls, name: str, b: ArrayLike, c: ArrayLike) -> Glass:
        """A glass the catalogue does not hold, from its maker's Sellmeier coefficients
        (``nd`` and ``vd`` computed from them).

        Examples
        --------
        >>> bk7 = get_glass("N-BK7")
        >>> own = Glass.from_sellmeier("my melt", bk7.b, bk7.c)
        >>> round(own.nd, 5), round(own.vd, 2)
        (1.5168, 64.17)
        """
        b3 = tuple(float(x) for x in np.asarray(b, dtype=np.float64).ravel())
        c3 = tuple(float(x) for x in np.asarray(c, dtype=np.float64).ravel())
        nd, nf, nc = sellmeier_index([D_LINE_NM, F_LINE_NM, C_LINE_NM], b3, c3)
        # Coefficients that are no glass may give no dispersion at all: the rig check
        # refuses them with its own message, so no warning here.
        with np.errstate(divide="ignore", invalid="ignore"):
            vd = float((nd - 1) / (nf - nc))
        return cls(str(name), b3, c3, float(nd), vd)  # type: ignore[arg-type]


GLASSES: dict[str, Glass] = {
    g.name: g
    for g in (
        Glass("N-BK7", (1.03961212, 0.231792344, 1.01046945),
              (0.00600069867, 0.0200179144, 103.560653), 1.51680, 64.17),
        Glass("F2", (1.34533359, 0.209073176, 0.937357162),
              (0.00997743871, 0.0470450767, 111.886764), 1.62004, 36.37),
        Glass("N-F2", (1.39757037, 0.159201403, 1.2686543),
              (0.00995906143, 0.0546931752, 119.248346), 1.62005, 36.43),
        Glass("N-SF5", (1.52481889, 0.187085527, 1.42729015),
              (0.011254756, 0.0588995392, 129.141675), 1.67271, 32.25),
        Glass("SF10", (1.61625977, 0.259229334, 1.07762317),
              (0.0127534559, 0.0581983954, 116.60768), 1.72825, 28.41),
        Glass("N-SF10", (1.62153902, 0.256287842, 1.64447552),
              (0.0122241457, 0.0595736775, 147.468793), 1.72828, 28.53),
        Glass("SF11", (1.73848403, 0.311168974, 1.17490871),
              (0.0136068604, 0.0615960463, 121.922711), 1.78472, 25.76),
        Glass("N-SF11", (1.73759695, 0.313747346, 1.89878101),
              (0.013188707, 0.0623068142, 155.23629), 1.78472, 25.68),
        Glass("N-SF6", (1.77931763, 0.338149866, 2.08734474),
              (0.0133714182, 0.0617533621, 174.01759), 1.80518, 25.36),
    )
}  # fmt: skip


def get_glass(name: str) -> Glass:
    """Look up a glass by catalog name (case-insensitive).

    Parameters
    ----------
    name
        Catalog name such as ``"N-SF11"`` or ``"n-bk7"``.

    Returns
    -------
    Glass

    Raises
    ------
    ConfigError
        If the glass is not in the built-in catalog; the message lists the known ones.

    Examples
    --------
    >>> get_glass("n-sf11").name
    'N-SF11'
    """
    for key, glass in GLASSES.items():
        if key.lower() == str(name).lower():
            return glass
    known = ", ".join(GLASSES)
    raise ConfigError(
        step_error(
            "prism.glass",
            f"unknown glass {name!r}{did_you_mean(name, GLASSES)}",
            f"use one of {known}, or give the glass's Sellmeier coefficients from its maker's "
            "data sheet in the rig description: prism.sellmeier: {b: [B1, B2, B3], c: [C1, C2, "
            "C3]} (C in square micrometres)",
        )
    )


def refractive_index(glass: str | Glass, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
    """Refractive index of ``glass`` at ``wavelength_nm``.

    Parameters
    ----------
    glass
        A :class:`Glass` or a catalog name.
    wavelength_nm
        Vacuum wavelength(s) in nm; any shape.

    Returns
    -------
    ndarray
        Index with the shape of ``wavelength_nm``.

    Examples
    --------
    >>> n = refractive_index("N-SF11", [450.0, 650.0])
    >>> bool(n[0] > n[1])
    True
    """
    g = glass if isinstance(glass, Glass) else get_glass(glass)
    return g.index(wavelength_nm)
