"""Reference reflectances of the X-Rite ColorChecker Classic, and their binning.

The reference comes from colour-science's datasets (BabelColor's average of 30 charts by
default, or Ohta's measurements) or from a CSV the lab supplies (its own chart measured on a
spectrophotometer). Measured spectra are averages over the bundle's wavelength bins, so the
reference is averaged over the same bins before any comparison.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError, step_error

__all__ = ["PATCH_COUNT", "WHITE_PATCH", "ReferenceChart", "read_chart_csv", "reference_chart"]

#: Patches of a ColorChecker Classic, in reading order (4 rows of 6).
PATCH_COUNT = 24
#: Index (0-based, reading order) of the white patch (white 9.5).
WHITE_PATCH = 18

_ALIASES = {
    "babelcolor": "BabelColor Average",
    "babelcolor average": "BabelColor Average",
    "ohta": "ColorChecker N Ohta",
    "colorchecker n ohta": "ColorChecker N Ohta",
}


@dataclass(frozen=True)
class ReferenceChart:
    """Reference reflectances of the 24 patches.

    Attributes
    ----------
    name
        Where the data come from (dataset name or CSV path).
    wavelengths_nm
        Sample wavelengths (L,), increasing.
    reflectance
        (24, L) reflectance factors in reading order.
    patch_names
        The 24 patch names.
    """

    name: str
    wavelengths_nm: NDArray[np.float64]
    reflectance: NDArray[np.float64]
    patch_names: tuple[str, ...]

    def bin_average(self, bin_edges_nm: ArrayLike) -> NDArray[np.float64]:
        """Mean reflectance of every patch over each bin (linear interpolation, box average).

        Parameters
        ----------
        bin_edges_nm
            Bin edges (B + 1,), inside the reference's wavelength range.

        Returns
        -------
        ndarray
            (24, B) float64.

        Examples
        --------
        >>> chart = reference_chart("BabelColor Average")
        >>> chart.bin_average([400.0, 500.0, 600.0, 700.0]).shape
        (24, 3)
        """
        edges = np.asarray(bin_edges_nm, dtype=np.float64)
        lam = self.wavelengths_nm
        if edges[0] < lam[0] - 1e-9 or edges[-1] > lam[-1] + 1e-9:
            raise ConfigError(
                step_error(
                    "Macbeth reference",
                    f"the reference {self.name!r} covers {lam[0]:g}-{lam[-1]:g} nm, the bundle's "
                    f"bins {edges[0]:.1f}-{edges[-1]:.1f} nm",
                    "use reference data covering every bin (BabelColor Average, Ohta, or a "
                    "wider CSV)",
                )
            )
        fine = np.arange(lam[0], lam[-1] + 0.05, 0.1)
        values = np.stack([np.interp(fine, lam, row) for row in self.reflectance])
        cumulative = (
            np.concatenate(
                [
                    np.zeros((values.shape[0], 1)),
                    np.cumsum((values[:, 1:] + values[:, :-1]) / 2, 1),
                ],
                axis=1,
            )
            * 0.1
        )
        at_edges = np.stack([np.interp(edges, fine, row) for row in cumulative])
        return np.diff(at_edges, axis=1) / np.diff(edges)


def reference_chart(source: str | os.PathLike[str] = "BabelColor Average") -> ReferenceChart:
    """Reference ColorChecker reflectances by dataset name or CSV path.

    Parameters
    ----------
    source
        ``"BabelColor Average"`` (default), ``"ColorChecker N Ohta"`` (aliases ``babelcolor``,
        ``ohta``), or a CSV path (see :func:`read_chart_csv`).

    Examples
    --------
    >>> chart = reference_chart("ohta")
    >>> chart.reflectance.shape[0], chart.patch_names[18]
    (24, 'white 9.5 (.05 D)')
    """
    text = str(source)
    name = _ALIASES.get(text.strip().lower(), text)
    if Path(text).suffix.lower() == ".csv":
        return read_chart_csv(text)
    import colour

    if name not in ("BabelColor Average", "ColorChecker N Ohta"):
        raise ConfigError(
            step_error(
                "Macbeth reference",
                f"unknown reference data {text!r}",
                "use 'BabelColor Average', 'ColorChecker N Ohta' or a CSV file path",
            )
        )
    sds = colour.SDS_COLOURCHECKERS[name]
    first = next(iter(sds.values()))
    lam = np.asarray(first.wavelengths, dtype=np.float64)
    table = np.stack([np.asarray(sd.values, dtype=np.float64) for sd in sds.values()])
    return ReferenceChart(name, lam, table, tuple(sds.keys()))


def read_chart_csv(path: str | os.PathLike[str]) -> ReferenceChart:
    """Read a chart's reflectances from CSV: wavelength_nm, then 24 patch columns.

    A header line (patch names) is optional; ``#`` starts a comment. Values may be
    reflectance factors (0-1) or percent (detected when the largest value exceeds 2).

    Examples
    --------
    >>> import tempfile
    >>> rows = [",".join([str(w)] + ["0.5"] * 24) for w in (380, 550, 780)]
    >>> with tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False) as f:
    ...     _ = f.write("\\n".join(rows))
    >>> read_chart_csv(f.name).reflectance.shape
    (24, 3)
    """
    file = Path(path)
    if not file.is_file():
        raise ConfigError(
            step_error("Macbeth reference", f"no such file {str(file)!r}", "give a CSV path")
        )
    lines = [ln for ln in file.read_text().splitlines() if ln.strip() and not ln.startswith("#")]
    names: tuple[str, ...] | None = None
    try:
        float(lines[0].split(",")[0])
    except (ValueError, IndexError):
        names = tuple(c.strip() for c in lines[0].split(",")[1:])
        lines = lines[1:]
    try:
        table = np.array([[float(c) for c in ln.split(",")] for ln in lines], dtype=np.float64)
    except ValueError as exc:
        raise ConfigError(
            step_error("Macbeth reference", f"{file}: not numeric ({exc})", "fix the CSV")
        ) from exc
    if table.ndim != 2 or table.shape[1] != PATCH_COUNT + 1 or table.shape[0] < 3:
        raise ConfigError(
            step_error(
                "Macbeth reference",
                f"{file}: expected rows of wavelength_nm and 24 reflectances, got shape "
                f"{table.shape}",
                "write one row per wavelength: wavelength_nm,patch1,...,patch24",
            )
        )
    table = table[np.argsort(table[:, 0])]
    values = table[:, 1:].T
    if values.max() > 2.0:
        values = values / 100.0
    if names is None or len(names) != PATCH_COUNT:
        names = tuple(f"patch {i + 1}" for i in range(PATCH_COUNT))
    return ReferenceChart(str(file), table[:, 0].copy(), values, names)
