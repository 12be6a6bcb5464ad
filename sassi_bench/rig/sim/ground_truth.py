"""Ground truth of the virtual bench, for tests and accuracy reports only.

Procedures never receive this object: they get device handles. Tests and accuracy
reports call :func:`truth` to score what a procedure measured. Everything here is the
bench as built (its ``as_built`` section applied), not as described.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.optics.sources import SpectralSamples
from sassi_bench.rig.rig import Rig
from sassi_bench.rig.sim import as_built
from sassi_bench.rig.sim.bench import VirtualBench
from sassi_bench.rig.sim.drift import DriftState
from sassi_bench.rig.sim.scenes import ScenePose, posed_scene

__all__ = ["BenchTruth", "register_bench", "truth"]

_BENCHES: dict[int, VirtualBench] = {}


def register_bench(rig: Rig, bench: VirtualBench) -> None:
    """Remember which bench backs ``rig`` (until the rig is garbage-collected)."""
    key = id(rig)
    _BENCHES[key] = bench
    weakref.finalize(rig, _BENCHES.pop, key, None)


@dataclass(frozen=True)
class BenchTruth:
    """What the virtual bench really is.

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> from sassi_bench.rig.sim import truth
    >>> t = truth(open_rig("sim"))
    >>> x, y = t.slm_to_camera(320, 200, 550.0)
    >>> round(t.contrast_eps, 4)
    0.001
    """

    _bench: VirtualBench

    def slm_to_camera(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera (x, y) of SLM pixel (u, v) at a wavelength (vectorised)."""
        return self._bench.relay.forward(u, v, wavelength_nm)

    @property
    def clock_h(self) -> float:
        """The bench clock (hours; ``nuisance.drift``): the optics are drifted to it."""
        return self._bench.clock_h

    def set_clock(self, hours: float) -> None:
        """Move the bench clock, and its drifted optics, to ``hours`` (tests only)."""
        self._bench.set_clock(hours)

    def drift_at(self, hours: float):
        """The optics' drift (:class:`~sassi_bench.rig.sim.drift.DriftState`) at ``hours``."""
        if self._bench.drift is None:
            return DriftState()
        return self._bench.drift.state_at(hours)

    @property
    def guide_to_slm(self) -> NDArray[np.float64]:
        """The 3x3 homography from guide pixels (p, q, 1) to SLM pixels (u, v, 1)."""
        return self._bench.guide.guide_to_slm.copy()

    def blur_sigma_px(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The optics' PSF sigma (camera px) at a wavelength, as built."""
        return self._bench.blur(wavelength_nm)

    def line_spread_sigma_px(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Sigma of the spot one SLM pixel makes, including pixel apertures."""
        return self._bench.renderer.spot_sigma(np.asarray(wavelength_nm, dtype=np.float64))

    def spot_covariance(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """Covariance (cxx, cyy, cxy; camera px**2) of the spot SLM pixel (u, v) makes at a
        wavelength as the camera records it (optics, SLM pixel aperture and camera pixel),
        broadcast. On a parametric bench the spot is round: ``cxy`` is 0.

        Examples
        --------
        >>> from sassi_bench import open_rig
        >>> from sassi_bench.rig.sim import truth
        >>> cxx, cyy, cxy = truth(open_rig("sim")).spot_covariance(320, 200, 550.0)
        >>> bool(cxx == cyy), float(cxy)
        (True, 0.0)
        """
        renderer = self._bench.renderer
        if hasattr(renderer, "spot_covariance"):
            return renderer.spot_covariance(u, v, wavelength_nm)
        u, v, lam = np.broadcast_arrays(
            *(np.asarray(a, dtype=np.float64) for a in (u, v, wavelength_nm))
        )
        var = renderer.spot_sigma(lam.ravel()).reshape(lam.shape) ** 2
        return var, var.copy(), np.zeros_like(var)

    @property
    def is_design(self) -> bool:
        """Whether the bench renders a traced optical design (a ``design:`` rig)."""
        return self._bench.description.design is not None

    @property
    def contrast_eps(self) -> float:
        """Closed-pixel transmission of the SLM (1 / contrast ratio)."""
        return self._bench.eps

    @property
    def wavelengths_nm(self) -> NDArray[np.float64]:
        """The scene wavelength grid."""
        return self._bench.grid.copy()

    def scene_cube(
        self, name: str | None = None, pose: ScenePose | None = None
    ) -> tuple[NDArray[np.float32], NDArray[np.float64]]:
        """Reflectance cube (H, W, L) on the SLM grid and its wavelengths.

        Without ``name``, the scene in front of the bench (at its current pose);
        with ``name``, that scene at ``pose`` (default: static).
        """
        bench = self._bench
        if name is None:
            scene = bench.scene
        else:
            scene = posed_scene(bench.scene_named(name), pose or ScenePose(), bench.slm_shape)
        return scene.cube(bench.slm_shape), bench.grid.copy()

    def binned_cube(
        self,
        bin_edges_nm: ArrayLike,
        light: str,
        scene: str | None = None,
        pose: ScenePose | None = None,
    ) -> NDArray[np.float64]:
        """What an ideal scan measures: (H, W, B) photo-electron rate per bin.

        The scene's reflectance times the light's photons times the camera's QE, each
        spectral sample spread over its own step of the grid and integrated into the bins.
        Equal to a scan cube up to one overall gain. ``scene`` and ``pose`` as in
        :meth:`scene_cube`.
        """
        edges = np.asarray(bin_edges_nm, dtype=np.float64)
        reflectance, grid = self.scene_cube(scene, pose)
        samples = self.light_samples(light)
        if not np.array_equal(samples.wavelengths_nm, grid):
            raise ValueError("binned_cube: the light is not sampled on the scene grid")
        rate = samples.weights * self.quantum_efficiency(grid)
        step = np.gradient(grid)
        low, high = grid - step / 2, grid + step / 2
        overlap = np.minimum(high[None], edges[1:, None]) - np.maximum(low[None], edges[:-1, None])
        weights = np.clip(overlap, 0.0, None) / step[None] * rate[None]
        return np.einsum("hwl,bl->hwb", reflectance, weights)

    def quantum_efficiency(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The spectral camera's QE."""
        return self._bench.sensor.quantum_efficiency(wavelength_nm)

    def _streaks_on_grid(self, model, field_points: tuple[int, int]):
        """A model's and the true streaks (x, y) on a grid of ``field_points`` (columns,
        rows) over the SLM at 61 wavelengths from 400 to 700 nm, and those wavelengths."""
        h, w = self._bench.slm_shape
        u, v = np.meshgrid(
            np.linspace(0, w - 1, field_points[0]), np.linspace(0, h - 1, field_points[1])
        )
        lam = np.linspace(400.0, 700.0, 61)
        modelled = model.evaluate(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
        true = self.slm_to_camera(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
        return modelled, true, lam

    def wavelength_map_error_nm(self, model, field_points: tuple[int, int] = (17, 11)) -> NDArray:
        """Wavelength error (nm) of a dispersion model's streak columns against the truth.

        ``model.evaluate(u, v, wavelength)`` (a bundle's dispersion model) is compared
        with the true ray trace on a grid of ``field_points`` (columns, rows) over the
        SLM at 61 wavelengths from 400 to 700 nm; column errors become wavelength errors
        through the true local dispersion. Returns (points, 61).
        """
        (xm, _), (xt, _), lam = self._streaks_on_grid(model, field_points)
        return (xm - xt) / np.gradient(xt, lam, axis=1)

    def row_error_px(self, model, field_points: tuple[int, int] = (17, 11)) -> NDArray:
        """Error (camera px) of a dispersion model's streak rows against the truth, on the
        grid and wavelengths of :meth:`wavelength_map_error_nm`. Returns (points, 61)."""
        (_, ym), (_, yt), _ = self._streaks_on_grid(model, field_points)
        return np.asarray(ym - yt)

    def relative_response(self, bin_edges_nm: ArrayLike, light: str = "halogen") -> NDArray:
        """What a radiometric response taken under ``light`` should be, per bin.

        The spectral camera's QE weighted by the light's photons in each bin (the
        response is relative: the optics' grey throughput and the exposure only scale it).
        """
        edges = np.asarray(bin_edges_nm, dtype=np.float64)
        grid = self.wavelengths_nm
        step = np.gradient(grid)
        low, high = grid - step / 2, grid + step / 2
        overlap = np.minimum(high[None], edges[1:, None]) - np.maximum(low[None], edges[:-1, None])
        share = np.clip(overlap, 0.0, None) / step[None]
        photons = self.light_samples(light).weights
        return (share * photons * self.quantum_efficiency(grid)).sum(1) / (share * photons).sum(1)

    def laser_centre_nm(self, nominal_nm: float) -> float:
        """The true centre (nm) of the laser line labelled ``nominal_nm``."""
        return as_built.laser_centre_nm(self._bench.description, nominal_nm)

    def lamp_lines(self, name: str):
        """The true lines of wavelength lamp ``name`` (its intensities as built)."""
        return as_built.lamp_lines(self._bench.description, name)

    @property
    def halogen_k(self) -> float:
        """The halogen lamp's true colour temperature (K)."""
        return as_built.halogen_k(self._bench.description)

    @property
    def guide_sensitivities(self) -> NDArray[np.float64]:
        """The guide camera's true RGB curves (3, L) on :attr:`wavelengths_nm`."""
        return self._bench.guide.sensitivities.copy()

    def light_samples(self, name: str) -> SpectralSamples:
        """The spectral samples of light ``name``."""
        return self._bench.samples(name)

    @property
    def bench(self) -> VirtualBench:
        """The bench itself (renderer, sensor, scenes), for tests that need more."""
        return self._bench


def truth(rig: Rig) -> BenchTruth:
    """Ground truth of a simulated rig (tests and accuracy reports only)."""
    bench = _BENCHES.get(id(rig))
    if bench is None:
        raise ValueError("truth: this rig is not a virtual bench opened in this process")
    return BenchTruth(bench)
