"""Rendering spectral-camera frames on the virtual bench.

Two exact-in-expectation renderers share one optical model (the ray-traced relay of
:mod:`~sassi_bench.rig.sim.geometry` and the spot width of
:func:`~sassi_bench.optics.blur.line_spread_sigma`):

* **dense** (:meth:`SpectralRenderer.render_dense`), for patterns with many open
  pixels: for every wavelength sample the SLM image is warped onto the camera through
  the inverse relay map (computed exactly on a coarse grid and interpolated; the map is
  smooth to far below a pixel), scaled by the local area ratio so energy is conserved,
  and blurred. Bilinear warping already spreads a pixel like a tent of one SLM pixel,
  so the blur adds only the variance still missing.
* **sparse** (:meth:`SpectralRenderer.render_sparse`), for pinholes and adaptive masks:
  every open pixel's streak is splatted as a sum over wavelength samples of separable
  Gaussians placed at the ray-traced positions, batched as one matrix product per
  pixel block and scattered into the frame with ``np.bincount``.

Both return the photo-electron rate (e-/s) per camera pixel; noise is added by the
sensor model. No Python loop runs over pixels: loops run over wavelength samples
(dense) or blocks of open pixels (sparse).
"""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from sassi_bench.optics.blur import BlurModel, line_spread_sigma
from sassi_bench.optics.sources import SpectralSamples
from sassi_bench.rig.sim.geometry import SpectralRelay, linear_upsampler
from sassi_bench.rig.sim.scenes import Scene

__all__ = ["SpectralRenderer"]

_TRUNCATE_SIGMAS = 4.0


class SpectralRenderer:
    """Photo-electron rates on the spectral camera for an SLM transmission and a scene.

    Parameters
    ----------
    relay
        The ray-traced SLM -> camera map.
    blur
        The optics PSF sigma versus wavelength.
    fill_factor
        SLM pixel fill factor (its aperture's side over the pitch).
    quantum_efficiency
        Callable nm -> QE of the spectral camera.
    coarse_step
        Spacing (camera px) of the grid on which inverse maps are solved exactly.
    block
        Open pixels splatted per batch by the sparse renderer (bounds memory).
    """

    def __init__(
        self,
        relay: SpectralRelay,
        blur: BlurModel,
        fill_factor: float,
        quantum_efficiency,
        coarse_step: int = 8,
        block: int = 256,
    ) -> None:
        self.relay = relay
        self.blur = blur
        self.fill_factor = fill_factor
        self.quantum_efficiency = quantum_efficiency
        self.block = block
        hc, wc = relay.camera_shape
        self.camera_shape = (hc, wc)
        step = float(coarse_step)
        self._coarse_x = np.arange(-step, wc + step, step)
        self._coarse_y = np.arange(-step, hc + step, step)
        self._up_x = linear_upsampler(self._coarse_x, wc)
        self._up_y = linear_upsampler(self._coarse_y, hc)
        self._inverse_cache: dict[float, tuple[NDArray[np.float32], ...]] = {}

    # -- the optical model shared by both renderers ---------------------------------
    def spot_sigma(self, wavelength_nm: NDArray[np.float64]) -> NDArray[np.float64]:
        """Sigma (camera px) of the spot one SLM pixel makes, at each wavelength."""
        return line_spread_sigma(self.blur(wavelength_nm), self.relay.relay.scale, self.fill_factor)

    def electrons_per_photon(self, samples: SpectralSamples) -> NDArray[np.float64]:
        """Photo-electron rate each sample delivers per unit reflectance and transmission."""
        return samples.weights * self.quantum_efficiency(samples.wavelengths_nm)

    # -- dense ----------------------------------------------------------------------
    def _inverse_maps(self, wavelength_nm: float) -> tuple[NDArray[np.float32], ...]:
        """Coarse inverse map (u, v) and area ratio |d(u,v)/d(x,y)| at one wavelength."""
        key = round(float(wavelength_nm), 6)
        cached = self._inverse_cache.get(key)
        if cached is not None:
            return cached
        gx, gy = np.meshgrid(self._coarse_x, self._coarse_y)
        u, v = self.relay.inverse(gx, gy, key)
        step = self._coarse_x[1] - self._coarse_x[0]
        du_dy, du_dx = np.gradient(u, step)
        dv_dy, dv_dx = np.gradient(v, step)
        area = np.abs(du_dx * dv_dy - du_dy * dv_dx)
        maps = (u.astype(np.float32), v.astype(np.float32), area.astype(np.float32))
        if len(self._inverse_cache) > 4096:
            self._inverse_cache.clear()
        self._inverse_cache[key] = maps
        return maps

    def _upsample(self, coarse: NDArray[np.float32]) -> NDArray[np.float32]:
        return self._up_y @ coarse @ self._up_x.T

    def render_dense(
        self,
        transmission: NDArray[np.float32],
        scene: Scene,
        samples: SpectralSamples,
    ) -> NDArray[np.float32]:
        """Electron rate for a full SLM transmission image (H, W), by warping.

        Examples
        --------
        >>> from sassi_bench import open_rig
        >>> from sassi_bench.rig.sim import truth
        >>> bench = truth(open_rig("sim")).bench
        >>> rate = bench.renderer.render_dense(
        ...     np.ones(bench.slm_shape, np.float32), bench.scene, bench.samples("laser:532")
        ... )
        >>> rate.shape
        (512, 800)
        """
        rows, cols = scene.slm_window(transmission.shape)
        scale = self.relay.relay.scale
        rate = np.zeros(self.camera_shape, dtype=np.float32)
        gain = self.electrons_per_photon(samples)
        sigma = self.spot_sigma(samples.wavelengths_nm)
        # Bilinear warping spreads an SLM pixel like a tent of variance scale^2 / 6.
        extra = np.sqrt(np.clip(sigma**2 - scale**2 / 6.0, 0.0, None))
        for lam, g, s in zip(samples.wavelengths_nm, gain, extra, strict=True):
            if g <= 0:
                continue
            source = transmission * scene.reflectance_image(lam)[rows, cols]
            cu, cv, carea = self._inverse_maps(lam)
            warped = cv2.remap(
                source,
                self._upsample(cu),
                self._upsample(cv),
                interpolation=cv2.INTER_LINEAR,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=0.0,
            )
            warped *= self._upsample(carea) * np.float32(g)
            if s > 0.05:
                warped = cv2.GaussianBlur(warped, (0, 0), sigmaX=float(s), sigmaY=float(s))
            rate += warped
        return rate

    # -- sparse ---------------------------------------------------------------------
    def render_sparse(
        self,
        rows: NDArray[np.intp],
        cols: NDArray[np.intp],
        transmission: NDArray[np.float32],
        scene: Scene,
        samples: SpectralSamples,
    ) -> NDArray[np.float32]:
        """Electron rate for a few open SLM pixels, by splatting their streaks.

        Parameters
        ----------
        rows, cols
            SLM coordinates of the open pixels (N,).
        transmission
            Their transmissions (N,).
        """
        hc, wc = self.camera_shape
        total = np.zeros(hc * wc, dtype=np.float64)
        if rows.size == 0:
            return total.reshape(hc, wc).astype(np.float32)
        lam = samples.wavelengths_nm
        gain = self.electrons_per_photon(samples).astype(np.float32)
        sigma = self.spot_sigma(lam)
        inv_two_var = (0.5 / sigma**2).astype(np.float32)
        reach = int(np.ceil(_TRUNCATE_SIGMAS * sigma.max())) + 1
        for start in range(0, rows.size, self.block):
            r = rows[start : start + self.block]
            c = cols[start : start + self.block]
            spectra = scene.reflectance_at(r + scene.margin, c + scene.margin, lam)
            spectra *= gain[None, :] * transmission[start : start + self.block, None]
            x, y = self.relay.forward(c[:, None], r[:, None], lam[None, :])
            total += self._splat(x, y, spectra, inv_two_var, reach)
        return total.reshape(hc, wc).astype(np.float32)

    def _splat(self, x, y, spectra, inv_two_var, reach) -> NDArray[np.float64]:
        hc, wc = self.camera_shape
        x0 = np.floor(x.min(axis=1)).astype(np.intp) - reach
        y0 = np.floor(y.min(axis=1)).astype(np.intp) - reach
        width = int(np.ceil((x.max(axis=1) - x0).max())) + reach + 1
        height = int(np.ceil((y.max(axis=1) - y0).max())) + reach + 1
        px = (x0[:, None] + np.arange(width))[:, None, :].astype(np.float32)
        py = (y0[:, None] + np.arange(height))[:, None, :].astype(np.float32)
        gx = np.exp(-((px - x[:, :, None].astype(np.float32)) ** 2) * inv_two_var[None, :, None])
        gy = np.exp(-((py - y[:, :, None].astype(np.float32)) ** 2) * inv_two_var[None, :, None])
        # Normalise each sampled 1-D kernel so every sample deposits exactly its energy.
        gx /= gx.sum(axis=2, keepdims=True)
        gy /= gy.sum(axis=2, keepdims=True)
        gy *= spectra[:, :, None]
        patches = np.matmul(gy.transpose(0, 2, 1), gx)  # (N, height, width)
        cols = x0[:, None, None] + np.arange(width)[None, None, :]
        rows = y0[:, None, None] + np.arange(height)[None, :, None]
        inside = (cols >= 0) & (cols < wc) & (rows >= 0) & (rows < hc)
        index = (rows * wc + cols)[inside]
        return np.bincount(index, weights=patches[inside], minlength=hc * wc)
