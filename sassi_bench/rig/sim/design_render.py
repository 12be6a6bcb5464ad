"""Rendering a design rig: spots that change size, shape and orientation over the field.

A rig with a ``design:`` section renders from its traced design
(:class:`~sassi_bench.optics.design.relay.DesignRelay`, as built): every spot sits at its
traced centroid, with the traced covariance plus the diffraction core and the SLM
pixel's square aperture, weighted by the traced throughput (vignetting).

* **sparse** (pinholes, lamp and laser grids, masks): each (open pixel, sample) is a
  Gaussian of its own covariance, integrated over the camera pixels
  (:mod:`~sassi_bench.rig.sim._gauss_splat`): the bench's truth. A pixel's neighbouring
  samples that land within a fraction of their spot's width are drawn as one spot of the
  same moments (:mod:`~sassi_bench.rig.sim._spot_merge`).
* **dense** (grey levels, line sweeps, scenes): the SLM image warped through the traced
  map as on a parametric bench, then blurred at each wavelength by one kernel, the
  spot's covariance at the field's median, and weighted by the median throughput: the
  blur's change over the field is not rendered in dense frames. The calibration reads
  positions from dense frames (edges and line centres, which a symmetric blur does not
  move) and the blur from sparse ones.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from sassi_bench.optics.design.relay import DesignRelay
from sassi_bench.optics.sources import SpectralSamples
from sassi_bench.rig.sim._gauss_splat import splat_gaussians
from sassi_bench.rig.sim._spot_merge import merge_neighbouring_spots
from sassi_bench.rig.sim.render import SpectralRenderer
from sassi_bench.rig.sim.scenes import Scene

__all__ = ["DesignRenderer"]

# Field points (columns x rows of the SLM) the dense renderer's median spot is taken over.
_MEDIAN_GRID = (9, 5)
#: How far (a share of the smaller of cxx and cyy of the run's first sample) the median
#: spot covariance of a run of samples may stray for the run to be blurred by one kernel.
BLUR_RUN_TOLERANCE = 0.05


@lru_cache(maxsize=4096)
def _gaussian_kernel_2d(cxx: float, cyy: float, cxy: float) -> NDArray[np.float32]:
    """A normalised 2-D Gaussian kernel sampled at whole pixels (read-only)."""
    cov = np.array([[cxx, cxy], [cxy, cyy]])
    values, vectors = np.linalg.eigh(cov)
    values = np.maximum(values, 0.01)
    reach = max(1, int(np.ceil(4.0 * np.sqrt(values.max()))))
    j = np.arange(-reach, reach + 1, dtype=np.float64)
    d = np.stack(np.meshgrid(j, j, indexing="xy"), axis=-1)  # (..., [x, y])
    precision = vectors @ np.diag(1.0 / values) @ vectors.T
    kernel = np.exp(-0.5 * np.einsum("...i,ij,...j->...", d, precision, d))
    kernel = (kernel / kernel.sum()).astype(np.float32)
    kernel.setflags(write=False)
    return kernel


class DesignRenderer(SpectralRenderer):
    """Photo-electron rates on the spectral camera of a design rig.

    Parameters
    ----------
    relay
        The traced design, as built.
    fill_factor
        SLM pixel fill factor (its aperture's side over the pitch).
    quantum_efficiency
        Callable nm -> QE of the spectral camera.
    """

    def __init__(self, relay: DesignRelay, fill_factor: float, quantum_efficiency) -> None:
        super().__init__(relay, None, fill_factor, quantum_efficiency)  # type: ignore[arg-type]
        h, w = relay.slm_shape
        u, v = np.meshgrid(
            np.linspace(0, w - 1, _MEDIAN_GRID[0]), np.linspace(0, h - 1, _MEDIAN_GRID[1])
        )
        self._median_points = (u.ravel(), v.ravel())

    @property
    def aperture_variance(self) -> float:
        """Variance (camera px**2, each axis) of the SLM pixel's square aperture."""
        side = self.fill_factor * self.relay.scale
        return side**2 / 12.0

    def spot_covariance(self, u, v, wavelength_nm):
        """Covariance (cxx, cyy, cxy; camera px**2) of the spot one SLM pixel makes as a
        camera records it: the optics, the SLM pixel's aperture and the camera pixel."""
        cxx, cyy, cxy = self.relay.optics_covariance(u, v, wavelength_nm)
        boxes = self.aperture_variance + 1.0 / 12.0
        return cxx + boxes, cyy + boxes, cxy

    def spot_sigma(self, wavelength_nm: NDArray[np.float64]) -> NDArray[np.float64]:
        """The major-axis sigma (camera px) of the median spot over the field."""
        cxx, cyy, cxy = self._median_covariance(np.atleast_1d(wavelength_nm))
        boxes = self.aperture_variance + 1.0 / 12.0
        cxx, cyy = cxx + boxes, cyy + boxes
        return np.sqrt(0.5 * (cxx + cyy) + np.sqrt(0.25 * (cxx - cyy) ** 2 + cxy**2))

    def _median_covariance(self, wavelengths_nm: NDArray[np.float64]):
        u, v = self._median_points
        cov = self.relay.optics_covariance_grid(u, v, wavelengths_nm)
        return tuple(np.median(c, axis=0) for c in cov)

    def _dense_blurs(
        self, wavelengths_nm: NDArray[np.float64], gain: NDArray[np.float64]
    ) -> list[tuple[list[int], int, NDArray[np.float32] | None]]:
        """Runs of neighbouring lit samples whose median spots agree with the run's first
        within :data:`BLUR_RUN_TOLERANCE` of its smaller variance, each blurred once by the 2-D
        kernel of its gain-weighted mean covariance (the blur is linear, so a run's
        warped images are summed first)."""
        cxx, cyy, cxy = self._median_covariance(wavelengths_nm)
        # what the optics and the camera pixel add to the warp's tent of one SLM pitch
        extra = self.aperture_variance + 1.0 / 12.0 - self.relay.scale**2 / 6.0
        cov = np.stack([cxx + extra, cyy + extra, cxy], axis=1)
        runs: list[list[int]] = []
        for k in np.flatnonzero(gain > 0):
            if runs:
                start = cov[runs[-1][0]]
                tolerance = BLUR_RUN_TOLERANCE * max(min(start[0], start[1]), 0.05**2)
                if runs[-1][-1] == k - 1 and np.abs(cov[k] - start).max() <= tolerance:
                    runs[-1].append(int(k))
                    continue
            runs.append([int(k)])
        out: list[tuple[list[int], int, NDArray[np.float32] | None]] = []
        for run in runs:
            a, b, c = np.average(cov[run], axis=0, weights=gain[run])
            if max(a, b) < 0.05**2:
                out.append((run, 0, None))
                continue
            kernel = _gaussian_kernel_2d(round(float(a), 4), round(float(b), 4), round(float(c), 4))
            out.append((run, kernel.shape[0] // 2, kernel))
        return out

    def electrons_per_photon(self, samples: SpectralSamples) -> NDArray[np.float64]:
        """Photo-electron rate each sample delivers (dense frames: the median throughput)."""
        u, v = self._median_points
        throughput = np.median(self.relay.throughput_grid(u, v, samples.wavelengths_nm), axis=0)
        return samples.weights * self.quantum_efficiency(samples.wavelengths_nm) * throughput

    def render_sparse(
        self,
        rows: NDArray[np.intp],
        cols: NDArray[np.intp],
        transmission: NDArray[np.float32],
        scene: Scene,
        samples: SpectralSamples,
        base: NDArray[np.float32] | None = None,
    ) -> NDArray[np.float32]:
        """Electron rate for a few open SLM pixels: each spot a pixel-integrated Gaussian
        of its own covariance at its traced centroid, weighted by its throughput."""
        if base is None:
            total = np.zeros(self.camera_shape, dtype=np.float32)
        else:
            total = np.array(base, dtype=np.float32, copy=True)
        if rows.size == 0:
            return total
        lam = samples.wavelengths_nm
        relay: DesignRelay = self.relay  # type: ignore[assignment]
        gain = samples.weights * self.quantum_efficiency(lam)
        spectra = scene.reflectance_at(rows + scene.margin, cols + scene.margin, lam)
        spectra = spectra * gain[None, :] * np.asarray(transmission, np.float64)[:, None]
        x, y, cxx, cyy, cxy, throughput = relay.spots_grid(cols, rows, lam)
        spectra *= throughput
        cxx += self.aperture_variance
        cyy += self.aperture_variance
        splat_gaussians(*merge_neighbouring_spots(x, y, cxx, cyy, cxy, spectra), total)
        return total
