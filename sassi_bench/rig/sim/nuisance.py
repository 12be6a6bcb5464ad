"""Real-bench nuisances the virtual bench renders (a rig's bench-only ``nuisance`` section).

A real bench is not the clean model the rest of the virtual bench renders. These are
the deviations a procedure must either survive or name:

* **laser power jitter**: a laser's power drifts from frame to frame; every frame lit by
  a laser is scaled by one factor ``1 + j z``, ``z`` standard normal, drawn from the
  frame's own noise stream (so frames stay reproducible and resumable);
* **hot pixels**: a fixed set of spectral-camera pixels with a large dark current
  (log-uniform from 3 % to 300 % of the full well per second), in every frame, light
  or not, with its shot noise;
* **SLM crosstalk**: the fringing field of an LCoS pixel lets a fraction ``c`` of an open
  pixel's transmission into each of its 4-neighbours (the pixel keeps ``1 - 4c``);
  applied to the SLM transmission pattern, so it reaches every renderer;
* **stray light**: a fraction of the scene light reaching the sensor in a frame is
  scattered evenly over the whole sensor;
* **speckle**: under laser light a static grain multiplies the image on the sensor, a
  log-normal field of mean 1 and contrast ``std / mean`` correlated over about 1.5 px,
  fixed per laser line (speckle decorrelates between lines).

Every nuisance defaults to zero, and with zero the bench's frames are exactly those
of a rig without the section. Everything is deterministic from the rig's seed.

Examples
--------
>>> from sassi_bench.rig.sim.sections import NuisanceConfig
>>> nuisances = BenchNuisances(NuisanceConfig(hot_pixels_fraction=0.001), (100, 200), 7, 3e4)
>>> int(np.count_nonzero(nuisances.hot_pixel_rate))
20
>>> BenchNuisances(NuisanceConfig(), (100, 200), 7, 3e4).active
False
"""

from __future__ import annotations

import hashlib

import cv2
import numpy as np
from numpy.typing import NDArray

from sassi_bench.rig.lights import kind_of
from sassi_bench.rig.sim.sections import NuisanceConfig

__all__ = ["BenchNuisances", "crosstalk", "speckle_field"]

# Hot-pixel dark current, as a fraction of the full well per second (log-uniform).
_HOT_RATE_RANGE = (0.03, 3.0)
# Correlation length (Gaussian sigma, camera px) of the speckle grain.
_SPECKLE_SIGMA_PX = 1.5
# Streams of the rig seed used here (the bench uses 2 for its scenes).
_HOT_STREAM, _SPECKLE_STREAM = 11, 12


def crosstalk(excess: NDArray[np.float32], fraction: float) -> NDArray[np.float32]:
    """Spread ``fraction`` of every pixel's transmission into each of its 4-neighbours.

    Energy is conserved inside the SLM: a pixel keeps ``1 - 4 fraction`` of its own
    transmission (light spilled past the SLM's border is lost).

    Parameters
    ----------
    excess
        Transmission above the closed level (H, W).
    fraction
        Share of a pixel's light in each 4-neighbour.

    Examples
    --------
    >>> t = np.zeros((3, 3), np.float32)
    >>> t[1, 1] = 1.0
    >>> crosstalk(t, 0.05).astype(float).round(3).tolist()
    [[0.0, 0.05, 0.0], [0.05, 0.8, 0.05], [0.0, 0.05, 0.0]]
    """
    if fraction <= 0:
        return excess
    kernel = np.array(
        [[0.0, fraction, 0.0], [fraction, 1.0 - 4.0 * fraction, fraction], [0.0, fraction, 0.0]],
        dtype=np.float32,
    )
    return cv2.filter2D(excess.astype(np.float32), -1, kernel, borderType=cv2.BORDER_CONSTANT)


def speckle_field(
    shape: tuple[int, int], contrast: float, rng: np.random.Generator
) -> NDArray[np.float32]:
    """A static log-normal speckle field of mean 1 and ``std / mean = contrast``.

    A white Gaussian field is smoothed to a grain of about 1.5 px and rescaled to unit
    variance, then ``exp(s g - s^2 / 2)`` with ``s^2 = ln(1 + contrast^2)`` has exactly
    the asked mean and contrast.

    Examples
    --------
    >>> field = speckle_field((256, 256), 0.2, np.random.default_rng(0))
    >>> round(float(field.mean()), 2), round(float(field.std() / field.mean()), 2)
    (1.0, 0.2)
    """
    white = rng.standard_normal(shape).astype(np.float32)
    smooth = cv2.GaussianBlur(white, (0, 0), _SPECKLE_SIGMA_PX, borderType=cv2.BORDER_REFLECT)
    smooth /= np.float32(smooth.std())
    s = float(np.sqrt(np.log1p(contrast**2)))
    return np.exp(np.float32(s) * smooth - np.float32(s * s / 2)).astype(np.float32)


class BenchNuisances:
    """The nuisances of one virtual bench, fixed at construction from the rig's seed.

    Parameters
    ----------
    config
        The rig's ``nuisance`` section.
    camera_shape
        The spectral camera's (rows, columns).
    seed
        The rig's seed.
    full_well_e
        The spectral camera's full well (scales the hot pixels' dark current).
    """

    def __init__(
        self,
        config: NuisanceConfig,
        camera_shape: tuple[int, int],
        seed: int,
        full_well_e: float,
    ) -> None:
        self.config = config
        self.camera_shape = camera_shape
        self.seed = seed
        self.hot_pixel_rate = np.zeros(camera_shape, dtype=np.float32)
        if config.hot_pixels_fraction > 0:
            rng = np.random.default_rng([seed, _HOT_STREAM])
            count = round(config.hot_pixels_fraction * camera_shape[0] * camera_shape[1])
            where = rng.choice(self.hot_pixel_rate.size, size=count, replace=False)
            low, high = np.log10(_HOT_RATE_RANGE)
            rates = full_well_e * 10.0 ** rng.uniform(low, high, size=count)
            self.hot_pixel_rate.ravel()[where] = rates.astype(np.float32)
        self._speckle: dict[str, NDArray[np.float32]] = {}

    @property
    def active(self) -> bool:
        """Whether any nuisance is switched on."""
        c = self.config
        return any(
            v > 0
            for v in (
                c.laser_power_jitter,
                c.hot_pixels_fraction,
                c.slm_crosstalk,
                c.stray_light,
                c.speckle_contrast,
            )
        )

    def slm_excess(self, excess: NDArray[np.float32]) -> NDArray[np.float32]:
        """The SLM's transmission above the closed level, with crosstalk."""
        return crosstalk(excess, self.config.slm_crosstalk)

    def speckle(self, light: str) -> NDArray[np.float32]:
        """The static speckle field of laser ``light`` (built once per line)."""
        if light not in self._speckle:
            digest = hashlib.blake2b(light.encode(), digest_size=16).digest()
            words = np.frombuffer(digest, dtype=np.uint32).tolist()
            rng = np.random.default_rng([self.seed, _SPECKLE_STREAM, *words])
            self._speckle[light] = speckle_field(
                self.camera_shape, self.config.speckle_contrast, rng
            )
        return self._speckle[light]

    def spectral_rate(
        self, rate: NDArray[np.float32], light: str, rng: np.random.Generator
    ) -> NDArray[np.float32]:
        """The spectral camera's electron rate with the nuisances of this frame.

        Parameters
        ----------
        rate
            Electron rate of the scene light (e-/s), as the renderer makes it.
        light
            The light that is on (coherent lights, lasers, get speckle and jitter).
        rng
            The frame's noise stream (drawn from only when jitter is on).

        Returns
        -------
        ndarray
            The rate the sensor integrates: speckled, with stray light, scaled by the
            laser's power of this frame, plus the hot pixels' dark current.
        """
        if not self.active:
            return rate
        c = self.config
        laser = kind_of(light).coherent
        out = rate
        if laser and c.speckle_contrast > 0:
            out = out * self.speckle(light)
        if c.stray_light > 0:
            out = out + np.float32(c.stray_light * float(out.sum(dtype=np.float64)) / out.size)
        if laser and c.laser_power_jitter > 0:
            out = out * np.float32(max(0.0, 1.0 + c.laser_power_jitter * rng.standard_normal()))
        if c.hot_pixels_fraction > 0:
            out = out + self.hot_pixel_rate
        return out.astype(np.float32, copy=False)
