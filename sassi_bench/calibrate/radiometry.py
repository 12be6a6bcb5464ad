"""Radiometric response: from camera units per bin to relative spectral radiance.

A white diffuser under a source of known spectrum (a halogen lamp as a blackbody of
its colour temperature, or a reference spectrum the lab supplies as CSV) is scanned;
each bin's mean signal over the diffuser divided by the source's photon flux in that
bin is the system's response (quantum efficiency, optics, bin width). Dividing a cube by
it gives relative spectral radiance (photons per bin).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError, ProcedureError, step_error
from sassi_bench.optics.sources import blackbody_power

__all__ = [
    "read_reference_csv",
    "response_from_white",
    "source_photons_in_bins",
    "temperature_sensitivity",
]


def read_reference_csv(
    path: str | os.PathLike[str],
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Read a reference spectrum CSV: two columns, wavelength (nm) and relative power.

    A header line is allowed; ``#`` starts a comment.
    """
    try:
        table = np.genfromtxt(Path(path), delimiter=",", comments="#", dtype=np.float64)
    except OSError as exc:
        raise ConfigError(
            step_error(
                "reference spectrum",
                f"cannot read {path} ({exc})",
                "give the path of a CSV of wavelength_nm,power",
            )
        ) from exc
    table = table[np.all(np.isfinite(table), axis=1)] if table.ndim == 2 else table
    if table.ndim != 2 or table.shape[1] < 2 or table.shape[0] < 3:
        raise ConfigError(
            step_error(
                f"reference spectrum {path}",
                "fewer than three rows of numbers",
                "give at least three rows of 'wavelength_nm,power'",
            )
        )
    order = np.argsort(table[:, 0])
    return table[order, 0], table[order, 1]


def source_photons_in_bins(
    bin_edges_nm: ArrayLike,
    temperature_k: float | None = None,
    reference: tuple[ArrayLike, ArrayLike] | None = None,
    step_nm: float = 0.1,
) -> NDArray[np.float64]:
    """Relative photon flux of the source in each bin (integrated on a fine grid).

    Parameters
    ----------
    bin_edges_nm
        Bin edges (B + 1,).
    temperature_k
        Blackbody colour temperature (a halogen lamp), or
    reference
        (wavelengths_nm, relative power) of a measured source spectrum.

    Examples
    --------
    >>> flux = source_photons_in_bins([400, 500, 600, 700], temperature_k=3000)
    >>> bool(np.all(np.diff(flux) > 0))  # a 3000 K lamp is red-heavy
    True
    """
    edges = np.asarray(bin_edges_nm, dtype=np.float64)
    fine = np.arange(edges[0], edges[-1] + step_nm / 2, step_nm)
    if reference is not None:
        lam, power = (np.asarray(a, dtype=np.float64) for a in reference)
        if fine[0] < lam[0] or fine[-1] > lam[-1]:
            raise ConfigError(
                step_error(
                    "radiometric response",
                    f"the reference spectrum covers {lam[0]:g}-{lam[-1]:g} nm, the bins "
                    f"{edges[0]:.1f}-{edges[-1]:.1f} nm",
                    "supply a reference spectrum covering all bins",
                )
            )
        spectrum = np.interp(fine, lam, power)
    elif temperature_k is not None:
        spectrum = blackbody_power(fine, temperature_k)
    else:
        raise ConfigError(
            step_error(
                "radiometric response",
                "the source spectrum is unknown",
                "give the source's temperature or a reference spectrum",
            )
        )
    photons = spectrum * fine
    cumulative = np.concatenate([[0.0], np.cumsum((photons[1:] + photons[:-1]) / 2 * step_nm)])
    at_edges = np.interp(edges, fine, cumulative)
    return np.diff(at_edges) / np.max(np.diff(at_edges))


def response_from_white(
    white: ArrayLike,
    source_bins: ArrayLike,
    reflectance: float | ArrayLike = 1.0,
    *,
    pixels: int,
) -> NDArray[np.float64]:
    """Per-bin response: the white diffuser's mean signal over source flux times reflectance.

    Parameters
    ----------
    white
        (B,) the white diffuser's mean light per bin (camera units per second), deblurred
        after averaging (:func:`~sassi_bench.spectra.scan_deblur.scan_mean_spectrum`).
    source_bins
        :func:`source_photons_in_bins` of the illuminating source.
    reflectance
        The diffuser's reflectance (scalar or per bin).
    pixels
        How many white pixels the mean is of.

    Examples
    --------
    >>> response_from_white([2.0, 4.0, 6.0], [1.0, 2.0, 2.0], pixels=50).tolist()
    [2.0, 2.0, 3.0]
    """
    mean = np.asarray(white, dtype=np.float64)
    if mean.ndim != 1 or pixels < 10:
        raise ProcedureError(
            step_error(
                "radiometric response",
                f"need the mean spectrum of at least ten white pixels, got {pixels} pixels "
                f"and shape {mean.shape}",
                "scan more of the white diffuser",
            )
        )
    return mean / (np.asarray(source_bins, dtype=np.float64) * np.asarray(reflectance))


def temperature_sensitivity(
    bin_edges_nm: ArrayLike, temperature_k: float, delta_k: float = 100.0
) -> NDArray[np.float64]:
    """How a response measured under a blackbody changes if the lamp is ``delta_k`` off.

    The response divides the white signal by the lamp's photons per bin, so a lamp that
    is really at ``temperature_k -/+ delta_k`` changes every bin by the ratio of the
    assumed to the true photons. An overall gain does not matter (the response is
    relative), so the change is given relative to the median bin's.

    Returns
    -------
    ndarray
        (2, B): the relative change of each bin's response for a lamp ``delta_k``
        cooler (row 0) and hotter (row 1) than ``temperature_k``.

    Examples
    --------
    >>> edges = np.linspace(400, 700, 31)
    >>> change = temperature_sensitivity(edges, 3000.0)
    >>> bool(change[1, 0] > 0 > change[1, -1])  # a hotter lamp has more blue than assumed
    True
    >>> round(float(np.abs(change).max()), 2)
    0.11
    """
    assumed = source_photons_in_bins(bin_edges_nm, temperature_k=temperature_k)
    out = []
    for true_k in (temperature_k - delta_k, temperature_k + delta_k):
        ratio = source_photons_in_bins(bin_edges_nm, temperature_k=true_k) / assumed
        out.append(ratio / np.median(ratio) - 1.0)
    return np.array(out)
