"""Camera sensor model: quantum efficiency, shot and read noise, dark signal, ADC.

A pixel collecting ``rate`` photo-electrons per second for ``t`` seconds records

    e ~ Poisson((rate + dark_current) t) + N(0, read_noise),   e <- min(e, full_well)
    ADU = clip(round(e / gain) + dark_offset, 0, 2^bits - 1)

so the variance in ADU is ``(mean_e + read_noise^2) / gain^2`` below saturation.

A frame is drawn in :data:`NOISE_BLOCKS` bands of rows, each from its own child of the
frame's random stream, in parallel threads (NumPy draws without the GIL): the bands and
their streams do not depend on the machine, so the same stream gives the same frame.
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

__all__ = ["NOISE_BLOCKS", "QE_CURVES", "SensorModel", "qe_curve"]

#: Bands of rows of a frame drawn from separate child streams (see the module's notes).
NOISE_BLOCKS = 4

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
    """Threads drawing a frame's bands of rows (one per core, at most NOISE_BLOCKS)."""
    return ThreadPoolExecutor(max_workers=max(1, min(NOISE_BLOCKS, os.cpu_count() or 1)))


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

    def mean_adu(self, electrons: ArrayLike) -> NDArray[np.float64]:
        """Noise-free ADU for a mean electron count (including saturation)."""
        e = np.minimum(np.asarray(electrons, dtype=np.float64), self.full_well_e)
        return np.clip(e / self.gain_e_per_adu + self.dark_offset_adu, 0, self.max_adu)

    def expose(
        self, electron_rate: NDArray[np.floating], exposure_s: float, rng: np.random.Generator
    ) -> NDArray[np.unsignedinteger]:
        """Integrate ``electron_rate`` (e-/s per pixel) for ``exposure_s`` with noise.

        Parameters
        ----------
        electron_rate
            Electron rate per pixel (e-/s), (H, W) or (H, W, C).
        exposure_s
            Integration time, s.
        rng
            The frame's random stream; its band ``i`` of rows is drawn from
            ``rng.spawn(NOISE_BLOCKS)[i]``.

        Returns
        -------
        ndarray
            Digitised frame, dtype :attr:`dtype`.
        """
        rate = np.asarray(electron_rate)
        out = np.empty(rate.shape, dtype=self.dtype)
        edges = [rate.shape[0] * band // NOISE_BLOCKS for band in range(NOISE_BLOCKS + 1)]
        streams = rng.spawn(NOISE_BLOCKS)

        def draw(band: int) -> None:
            rows = slice(edges[band], edges[band + 1])
            out[rows] = self._digitise(rate[rows], exposure_s, streams[band])

        for _ in _pool().map(draw, range(NOISE_BLOCKS)):
            pass
        return out

    def _digitise(
        self, electron_rate: NDArray[np.floating], exposure_s: float, rng: np.random.Generator
    ) -> NDArray[np.unsignedinteger]:
        """Noise and digitisation of one band of rows (see :meth:`expose`)."""
        mean_e = np.array(electron_rate, dtype=np.float64)
        mean_e += self.dark_current_e_per_s
        mean_e *= exposure_s
        np.maximum(mean_e, 0.0, out=mean_e)
        electrons = rng.poisson(mean_e).astype(np.float32)
        electrons += rng.standard_normal(electrons.shape, dtype=np.float32) * np.float32(
            self.read_noise_e
        )
        # A full pixel reads a constant: the well (and with the default gain the ADC)
        # clips after the read-out noise, as a saturated sCMOS pixel does.
        np.minimum(electrons, np.float32(self.full_well_e), out=electrons)
        electrons /= np.float32(self.gain_e_per_adu)
        electrons += np.float32(self.dark_offset_adu)
        np.rint(electrons, out=electrons)
        return np.clip(electrons, 0, self.max_adu).astype(self.dtype)
