"""Light-source spectra: laser lines of finite width, white LEDs, halogen, fluorescent.

Sources are described as spectral *photon* flux, the quantity a camera counts. A
source becomes :class:`SpectralSamples`: wavelengths and the photons per second each
sample carries per SLM pixel of a perfectly white scene (the sample's share of the
integral, so summing weights over samples gives the total flux).

The broadband spectra come from colour-science's datasets (CIE LED illuminants,
CIE F-series fluorescent illuminants) and Planck's law (halogen as a blackbody).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError
from sassi_bench.optics.datasets import require_dataset

__all__ = [
    "SpectralSamples",
    "blackbody_power",
    "broadband_samples",
    "coarser_samples",
    "colour_illuminant_power",
    "laser_samples",
    "wavelength_grid",
]

# Second radiation constant h*c/k in nm*K, for Planck's law.
_C2_NM_K = 1.438776877e7


@dataclass(frozen=True)
class SpectralSamples:
    """A light source as weighted wavelength samples.

    Parameters
    ----------
    wavelengths_nm
        Sample wavelengths, (K,).
    weights
        Photons per second per SLM pixel carried by each sample for a perfect white
        scene, (K,). ``weights.sum()`` is the source's total photon flux.

    Examples
    --------
    >>> s = laser_samples(532.0, fwhm_nm=1.0, flux=1e6)
    >>> round(float(s.weights.sum()))
    1000000
    """

    wavelengths_nm: NDArray[np.float64]
    weights: NDArray[np.float64]

    @property
    def mean_wavelength_nm(self) -> float:
        """Photon-weighted mean wavelength."""
        return float(np.sum(self.wavelengths_nm * self.weights) / np.sum(self.weights))


def wavelength_grid(start_nm: float, stop_nm: float, step_nm: float) -> NDArray[np.float64]:
    """Inclusive, uniform wavelength grid.

    Examples
    --------
    >>> wavelength_grid(390, 720, 2).size
    166
    """
    count = round((stop_nm - start_nm) / step_nm) + 1
    return start_nm + step_nm * np.arange(count, dtype=np.float64)


def laser_samples(centre_nm: float, fwhm_nm: float, flux: float, nodes: int = 7) -> SpectralSamples:
    """A laser line with a Gaussian line shape, sampled at Gauss-Hermite nodes.

    Gauss-Hermite quadrature integrates the line exactly for any smooth response up
    to high polynomial order, so the renderer needs only a handful of wavelengths per
    laser however narrow the line is.

    Parameters
    ----------
    centre_nm, fwhm_nm
        Line centre and full width at half maximum.
    flux
        Total photon flux (photons/s per SLM pixel on a white scene).
    nodes
        Number of quadrature nodes.

    Returns
    -------
    SpectralSamples

    Examples
    --------
    >>> s = laser_samples(450.0, 1.0, 1.0, nodes=5)
    >>> round(s.mean_wavelength_nm, 9)
    450.0
    """
    if fwhm_nm <= 0:
        raise ConfigError(f"light.laser_fwhm_nm must be > 0, got {fwhm_nm}")
    x, w = np.polynomial.hermite_e.hermegauss(nodes)  # weight exp(-x^2/2)
    sigma = fwhm_nm / (2.0 * np.sqrt(2.0 * np.log(2.0)))
    return SpectralSamples(centre_nm + sigma * x, flux * w / w.sum())


def blackbody_power(wavelength_nm: ArrayLike, temperature_k: float) -> NDArray[np.float64]:
    """Relative spectral power of a blackbody (Planck's law), peak-free scaling.

    Examples
    --------
    >>> p = blackbody_power([450.0, 650.0], 3000.0)
    >>> bool(p[1] > p[0])  # a 3000 K halogen is red-heavy
    True
    """
    lam = np.asarray(wavelength_nm, dtype=np.float64)
    return 1.0 / (lam**5 * np.expm1(_C2_NM_K / (lam * temperature_k)))


def colour_illuminant_power(
    name: str, wavelength_nm: ArrayLike, key: str = "light"
) -> NDArray[np.float64]:
    """Relative spectral power of a colour-science illuminant (e.g. ``"LED-B3"``, ``"FL2"``).

    Examples
    --------
    >>> p = colour_illuminant_power("LED-B3", [400.0, 550.0])
    >>> bool(p[0] < 0.1 * p[1])  # CIE LED spectra have almost no power at 400 nm
    True
    """
    sd = require_dataset("illuminant", name, key)
    lam = np.asarray(wavelength_nm, dtype=np.float64)
    return np.interp(lam, sd.wavelengths, sd.values, left=0.0, right=0.0)


def broadband_samples(
    power: NDArray[np.float64],
    grid_nm: NDArray[np.float64],
    flux: float,
    band_nm: tuple[float, float] = (400.0, 700.0),
) -> SpectralSamples:
    """Turn a relative spectral power distribution on a grid into photon samples.

    Power converts to photon flux in proportion to wavelength; the result is scaled so
    the photon flux inside ``band_nm`` totals ``flux``. Each sample's weight is its
    trapezoid share of the integral.

    Examples
    --------
    >>> grid = wavelength_grid(390, 720, 2)
    >>> s = broadband_samples(np.ones_like(grid), grid, 1e6)
    >>> band = (grid >= 400) & (grid <= 700)
    >>> 0.99e6 < s.weights[band].sum() < 1.01e6
    True
    """
    photons = np.clip(power, 0.0, None) * grid_nm
    step = np.gradient(grid_nm)
    density = photons * step
    in_band = (grid_nm >= band_nm[0]) & (grid_nm <= band_nm[1])
    total = density[in_band].sum()
    if total <= 0:
        raise ConfigError("light: the source has no power between 400 and 700 nm")
    return SpectralSamples(grid_nm.copy(), density * (flux / total))


def coarser_samples(samples: SpectralSamples, every: int) -> SpectralSamples:
    """Merge each run of ``every`` neighbouring samples into one.

    The merged sample carries the run's total weight at its weighted mean wavelength,
    so the flux and the mean wavelength of the light are kept.

    Examples
    --------
    >>> s = SpectralSamples(np.array([400.0, 402.0, 404.0, 406.0]), np.array([1.0, 1, 1, 3]))
    >>> c = coarser_samples(s, 2)
    >>> c.wavelengths_nm.tolist(), c.weights.tolist()
    ([401.0, 405.5], [2.0, 4.0])
    """
    starts = np.arange(0, samples.wavelengths_nm.size, every)
    weights = np.add.reduceat(samples.weights, starts)
    moments = np.add.reduceat(samples.weights * samples.wavelengths_nm, starts)
    plain = np.add.reduceat(samples.wavelengths_nm, starts) / np.diff(
        np.append(starts, samples.wavelengths_nm.size)
    )
    with np.errstate(invalid="ignore", divide="ignore"):
        centres = np.where(weights > 0, moments / weights, plain)
    return SpectralSamples(centres, weights)
