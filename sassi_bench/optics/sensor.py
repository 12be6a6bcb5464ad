"""Camera sensor model: quantum efficiency, shot and read noise, dark signal, ADC.

A pixel collecting ``rate`` photo-electrons per second for ``t`` seconds records

    e ~ Poisson((rate + dark_current) t) + N(0, read_noise),   e <- min(e, full_well)
    ADU = clip(round(e / gain) + dark_offset, 0, 2^bits - 1)

so the variance in ADU is ``(mean_e + read_noise^2) / gain^2`` below saturation.

The shot noise is drawn exactly (no Gaussian approximation at any mean): a frame is drawn
in :data:`NOISE_BANDS` bands of rows, each from its own child of the frame's random stream
(an SFC64 stream seeded from a ``SeedSequence`` child), by a compiled loop that draws the
Poisson count and the read noise of every pixel and digitises it
(:mod:`~sassi_bench.optics._noise_kernels`), in parallel threads. The bands and their
streams do not depend on the machine or its number of cores, so the same stream gives
the same frame.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import PchipInterpolator

__all__ = ["NOISE_BANDS", "QE_CURVES", "SensorModel", "qe_curve"]

#: Bands of rows of a frame drawn from separate child streams (see the module's notes):
#: enough for two to four cores to share a frame evenly, whatever its rows hold.
NOISE_BANDS = 16

# Representative quantum-efficiency curves (wavelength nm -> QE), read off makers'
# published plots. "scmos" resembles a front-illuminated scientific CMOS of the
# Orca Flash 4.0 class; "flat" is for tests.
QE_CURVES: dict[str, dict[float, float]] = {
    "scmos": {
        380: 0.30, 400: 0.45, 450: 0.66, 500: 0.77, 550: 0.82, 600: 0.78,
        650: 0.70, 700: 0.60, 750: 0.48,
    },
    "flat": {380: 1.0, 750: 1.0},
}  # fmt: skip


def qe_curve(spec: str | Mapping[float, float], key: str = "qe") -> PchipInterpolator:
    """Build a QE interpolant from a named curve or a mapping nm -> QE.

    Examples
    --------
    >>> qe = qe_curve("scmos")
    >>> 0.8 < float(qe(550.0)) < 0.85
    True
    """
    from sassi_bench.errors import ConfigError, did_you_mean, step_error

    if isinstance(spec, str):
        if spec not in QE_CURVES:
            raise ConfigError(
                step_error(
                    key,
                    f"unknown curve {spec!r}{did_you_mean(spec, QE_CURVES)}",
                    f"use one of {', '.join(QE_CURVES)} or a mapping nm -> QE",
                )
            )
        spec = QE_CURVES[spec]
    points = sorted((float(k), float(v)) for k, v in spec.items())
    lam = np.array([p[0] for p in points])
    val = np.array([p[1] for p in points])
    if lam.size < 2 or np.any(val < 0) or np.any(val > 1):
        raise ConfigError(
            step_error(key, "the curve is not two or more points", "give QE values from 0 to 1")
        )
    return PchipInterpolator(lam, val, extrapolate=True)


@lru_cache(maxsize=1)
def _pool() -> ThreadPoolExecutor:
    """Threads drawing a frame's bands of rows (one per core, at most NOISE_BANDS)."""
    return ThreadPoolExecutor(max_workers=max(1, min(NOISE_BANDS, os.cpu_count() or 1)))


@dataclass
class SensorModel:
    """Noise and digitisation of one camera sensor.

    Parameters
    ----------
    read_noise_e
        Read noise, electrons RMS.
    full_well_e
        Full-well capacity, electrons.
    bit_depth
        ADC bits; output is ``uint16`` for 9-16 bits, ``uint8`` for 8.
    dark_offset_adu
        Constant offset added by the ADC (a real camera's black level).
    dark_current_e_per_s
        Dark current, electrons per second per pixel.
    gain_e_per_adu
        Electrons per ADU; by default the full well spans the ADC range above the offset.
    qe
        Named QE curve or mapping nm -> QE.

    Examples
    --------
    >>> sensor = SensorModel(read_noise_e=5.0, full_well_e=30000.0, bit_depth=16)
    >>> frame = sensor.expose(np.full((4, 4), 1000.0), 0.01, np.random.default_rng(0))
    >>> frame.dtype
    dtype('uint16')
    """

    read_noise_e: float
    full_well_e: float
    bit_depth: int
    dark_offset_adu: float = 100.0
    dark_current_e_per_s: float = 0.5
    gain_e_per_adu: float | None = None
    qe: str | Mapping[float, float] = "scmos"
    _qe: PchipInterpolator = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._qe = qe_curve(self.qe)
        if self.gain_e_per_adu is None:
            self.gain_e_per_adu = self.full_well_e / (self.max_adu - self.dark_offset_adu)

    @property
    def max_adu(self) -> int:
        """Largest value the ADC can output."""
        return 2**self.bit_depth - 1

    @property
    def dtype(self) -> np.dtype:
        """Output dtype of frames."""
        return np.dtype(np.uint8 if self.bit_depth <= 8 else np.uint16)

    def quantum_efficiency(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """QE at ``wavelength_nm`` (vectorised, clipped to [0, 1])."""
        return np.clip(self._qe(np.asarray(wavelength_nm, dtype=np.float64)), 0.0, 1.0)

    def expose(
        self, electron_rate: NDArray[np.floating], exposure_s: float, rng: np.random.Generator
    ) -> NDArray[np.unsignedinteger]:
        """Integrate ``electron_rate`` (e-/s per pixel) for ``exposure_s`` with noise.

        Parameters
        ----------
        electron_rate
            Electron rate per pixel (e-/s), (H, W) or (H, W, C); taken as float32.
        exposure_s
            Integration time, s.
        rng
            The frame's random stream (a ``Generator`` made from a seed sequence); band
            ``i`` of :data:`NOISE_BANDS` bands of rows is drawn from the SFC64 stream of
            ``rng.bit_generator.seed_seq.spawn(NOISE_BANDS)[i]``.

        Returns
        -------
        ndarray
            Digitised frame, dtype :attr:`dtype`.

        Raises
        ------
        ValueError
            If a rate is NaN, or so large that no count can hold it.
        """
        from sassi_bench.optics import _noise_kernels as kernels

        rate = np.asarray(electron_rate)
        flat = np.ascontiguousarray(rate, dtype=np.float32).reshape(rate.shape[0], -1)
        out = np.empty(flat.shape, dtype=self.dtype)
        edges = [flat.shape[0] * band // NOISE_BANDS for band in range(NOISE_BANDS + 1)]
        states = [kernels.seed_state(seq) for seq in rng.bit_generator.seed_seq.spawn(NOISE_BANDS)]
        settings = (
            float(self.dark_current_e_per_s),
            float(exposure_s),
            float(self.read_noise_e),
            float(self.full_well_e),
            float(self.gain_e_per_adu),
            float(self.dark_offset_adu),
            float(self.max_adu),
        )

        def draw(band: int) -> int:
            rows = slice(edges[band], edges[band + 1])
            return kernels.expose_band(flat[rows], out[rows], states[band], *settings)

        if any(list(_pool().map(draw, range(NOISE_BANDS)))):
            raise ValueError(
                "sensor exposure: an electron rate is NaN or beyond 1e18 e- per exposure; "
                "the renderer must give finite rates"
            )
        return out.reshape(rate.shape)
