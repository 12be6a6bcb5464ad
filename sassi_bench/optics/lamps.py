"""Gas-discharge lamps: atomic line lists that anchor the wavelength axis.

A pen-ray lamp (mercury-argon, neon) emits atomic lines whose wavelengths are known to
about 0.001 nm, so the lines are absolute wavelength anchors for a spectrograph. The
package ships one cited table per lamp (``data/lamps/<name>.csv``: NIST Atomic Spectra
Database wavelengths in standard air, with typical relative intensities); a lab can name
its own CSV of lines instead. A table is ``#`` comment lines, then a header with a
``wavelength_nm`` column (air wavelengths, nm) and optionally ``relative_intensity``,
``element`` and ``note``, then one line per row.

Relative intensities vary with the lamp, its age and warm-up: the calibration fits them
and never trusts them; they only start the fit and set the virtual bench's lamp.

Examples
--------
>>> lines = load_line_list("HgAr")
>>> lines.light, len(lines.wavelengths_nm) > 10
('lamp:HgAr', True)
>>> lamp_name("ne"), shipped_lamps()
('Ne', ('HgAr', 'Ne'))
"""

from __future__ import annotations

import csv
import hashlib
import io
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import ConfigError, did_you_mean, step_error
from sassi_bench.optics.sources import SpectralSamples

__all__ = [
    "ANCHOR_BAND_NM",
    "LineList",
    "is_lamp_file",
    "lamp_name",
    "lamp_samples",
    "load_line_list",
    "shipped_lamps",
]

#: The band whose lines anchor the wavelength axis (the calibrated band).
ANCHOR_BAND_NM = (400.0, 700.0)
#: A line counts as an anchor when at least this fraction of the lamp's strongest line.
_ANCHOR_MIN_INTENSITY = 0.05
_TABLE_FIX = (
    "write '#' comment lines, then a header wavelength_nm,relative_intensity[,element,note] "
    "and one line per row (air wavelengths in nm)"
)


def shipped_lamps() -> tuple[str, ...]:
    """Names of the lamps whose line tables the package ships.

    Examples
    --------
    >>> shipped_lamps()
    ('HgAr', 'Ne')
    """
    folder = resources.files("sassi_bench.optics").joinpath("data", "lamps")
    return tuple(sorted(p.name[:-4] for p in folder.iterdir() if p.name.endswith(".csv")))


def is_lamp_file(entry: str) -> bool:
    """Whether a ``wavelength_lamps`` entry names a CSV file rather than a shipped lamp.

    Examples
    --------
    >>> is_lamp_file("HgAr"), is_lamp_file("lines/krypton.csv")
    (False, True)
    """
    return entry.lower().endswith(".csv") or "/" in entry or "\\" in entry


def lamp_name(entry: str, step: str = "wavelength_lamps") -> str:
    """The lamp's name for a ``wavelength_lamps`` entry: a shipped lamp's own spelling
    (matched regardless of case), or a CSV file's stem. Its light is ``lamp:<name>``.

    Raises
    ------
    ConfigError
        For a name that is neither a shipped lamp nor a CSV path, with the closest name.

    Examples
    --------
    >>> lamp_name("hgar"), lamp_name("lab/Kr.csv")
    ('HgAr', 'Kr')
    >>> lamp_name("Hg-Ar")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ConfigError: wavelength_lamps: unknown lamp 'Hg-Ar' (did you mean 'HgAr'?)...
    """
    if is_lamp_file(entry):
        return Path(entry).stem
    shipped = {name.lower(): name for name in shipped_lamps()}
    name = shipped.get(entry.strip().lower())
    if name is None:
        raise ConfigError(
            step_error(
                step,
                f"unknown lamp {entry!r}{did_you_mean(entry, shipped.values())}",
                f"use one of {', '.join(shipped.values())} or the path of a CSV of lines "
                "(wavelength_nm,relative_intensity)",
            )
        )
    return name


@dataclass(frozen=True, eq=False)
class LineList:
    """A lamp's emission lines.

    Attributes
    ----------
    name
        The lamp's name; its light is :attr:`light`.
    wavelengths_nm
        Line wavelengths in standard air, sorted (K,).
    relative_intensity
        Typical photon-count ratios, strongest line 1 (K,).
    elements
        The emitting species per line (``"Hg I"``), or ``""``.
    source
        Where the table came from: ``"shipped"`` or the file's path.
    sha256
        SHA-256 of the table's bytes (a bundle records which table anchored it).
    """

    name: str
    wavelengths_nm: NDArray[np.float64]
    relative_intensity: NDArray[np.float64]
    elements: tuple[str, ...]
    source: str
    sha256: str

    @property
    def light(self) -> str:
        """The light name of the lamp, ``lamp:<name>``."""
        return f"lamp:{self.name}"

    def anchors(self, band_nm: tuple[float, float] = ANCHOR_BAND_NM) -> NDArray[np.bool_]:
        """Lines inside ``band_nm`` with at least 5 % of the strongest line's intensity."""
        lam = self.wavelengths_nm
        bright = self.relative_intensity >= _ANCHOR_MIN_INTENSITY * self.relative_intensity.max()
        return (lam >= band_nm[0]) & (lam <= band_nm[1]) & bright


def _table_text(entry: str, base: Path | None, step: str) -> tuple[str, str]:
    """The CSV text of a lamp entry and where it came from."""
    if not is_lamp_file(entry):
        name = lamp_name(entry, step)
        file = resources.files("sassi_bench.optics").joinpath("data", "lamps", f"{name}.csv")
        return file.read_text(encoding="utf-8"), "shipped"
    path = Path(entry)
    if not path.is_absolute() and base is not None:
        path = base / path
    if not path.is_file():
        raise ConfigError(
            step_error(
                step,
                f"no such file {str(path)!r}",
                "give the path of a CSV of lines (relative to the rig YAML) or a shipped lamp "
                f"({', '.join(shipped_lamps())})",
            )
        )
    return path.read_text(encoding="utf-8", errors="replace"), str(path)


def _parse(text: str, label: str, step: str) -> tuple[NDArray, NDArray, tuple[str, ...]]:
    rows = [
        row
        for row in csv.reader(io.StringIO(text))
        if row and row[0].strip() and not row[0].lstrip().startswith("#")
    ]
    header = [h.strip().lower() for h in rows[0]] if rows else []
    if "wavelength_nm" not in header:
        raise ConfigError(step_error(step, f"{label} has no wavelength_nm column", _TABLE_FIX))
    lam_col = header.index("wavelength_nm")
    int_col = header.index("relative_intensity") if "relative_intensity" in header else None
    el_col = header.index("element") if "element" in header else None
    lam, intensity, elements = [], [], []
    for number, row in enumerate(rows[1:], start=2):
        try:
            lam.append(float(row[lam_col]))
            intensity.append(float(row[int_col]) if int_col is not None else 1.0)
        except (ValueError, IndexError) as exc:
            raise ConfigError(
                step_error(
                    step,
                    f"{label}: table row {number} ({','.join(row)!r}) is not numbers",
                    _TABLE_FIX,
                )
            ) from exc
        elements.append(row[el_col].strip() if el_col is not None and el_col < len(row) else "")
    lam_a, int_a = np.array(lam, dtype=np.float64), np.array(intensity, dtype=np.float64)
    if lam_a.size == 0:
        raise ConfigError(step_error(step, f"{label} lists no lines", _TABLE_FIX))
    if not np.all(np.isfinite(lam_a) & (lam_a > 0)) or not np.all(np.isfinite(int_a) & (int_a > 0)):
        raise ConfigError(
            step_error(
                step,
                f"{label} has a wavelength or intensity that is not a positive number",
                "give every line a wavelength in nm and a relative intensity > 0",
            )
        )
    order = np.argsort(lam_a, kind="stable")
    return lam_a[order], int_a[order] / int_a.max(), tuple(elements[i] for i in order)


def load_line_list(
    entry: str, *, base: str | Path | None = None, step: str = "wavelength_lamps"
) -> LineList:
    """Load a lamp's lines: a shipped lamp by name, or a CSV file.

    Parameters
    ----------
    entry
        A shipped lamp's name (``"HgAr"``, ``"Ne"``; any case) or the path of a CSV.
    base
        Folder a relative CSV path is taken from (the rig YAML's).
    step
        The step named in errors.

    Returns
    -------
    LineList

    Raises
    ------
    ConfigError
        On an unknown lamp, a missing or malformed file, or a lamp with fewer than two
        anchor lines (at least 5 % of its strongest) between 400 and 700 nm.

    Examples
    --------
    >>> ne = load_line_list("Ne")
    >>> ne.name, int(ne.anchors().sum()) >= 20
    ('Ne', True)
    """
    text, source = _table_text(entry, None if base is None else Path(base), step)
    name = lamp_name(entry, step)
    label = "its table" if source == "shipped" else Path(source).name
    lam, intensity, elements = _parse(text, label, step)
    lines = LineList(
        name=name,
        wavelengths_nm=lam,
        relative_intensity=intensity,
        elements=elements,
        source=source,
        sha256=hashlib.sha256(text.encode("utf-8")).hexdigest(),
    )
    found = int(lines.anchors().sum())
    if found < 2:
        low, high = ANCHOR_BAND_NM
        raise ConfigError(
            step_error(
                step,
                f"lamp {name!r} has {found} line(s) between {low:g} and {high:g} nm with at least "
                f"{100 * _ANCHOR_MIN_INTENSITY:g} % of its strongest line; anchoring needs at "
                "least 2",
                f"use a lamp with visible lines ({', '.join(shipped_lamps())}) or list them in "
                "its CSV",
            )
        )
    return lines


def lamp_samples(
    lines: LineList,
    flux: float,
    intensities: NDArray[np.float64] | None = None,
    band_nm: tuple[float, float] = ANCHOR_BAND_NM,
) -> SpectralSamples:
    """A lamp as spectral samples: one sample per line.

    A pen-ray lamp's lines are a few picometres wide, far narrower than anything the
    spectral camera resolves, so each line is one sample at its wavelength.

    Parameters
    ----------
    lines
        The lamp's lines.
    flux
        Photon flux (photons/s per SLM pixel on a white scene) of the lines inside
        ``band_nm``.
    intensities
        Relative line intensities to render instead of the table's (a lamp as built).

    Examples
    --------
    >>> s = lamp_samples(load_line_list("HgAr"), 1e6)
    >>> inside = (s.wavelengths_nm >= 400) & (s.wavelengths_nm <= 700)
    >>> round(float(s.weights[inside].sum()))
    1000000
    """
    weights = np.asarray(
        lines.relative_intensity if intensities is None else intensities, dtype=np.float64
    )
    lam = lines.wavelengths_nm
    inside = (lam >= band_nm[0]) & (lam <= band_nm[1])
    return SpectralSamples(lam.copy(), weights * (flux / weights[inside].sum()))
