"""Rendering spectral-camera frames on the virtual bench.

Two exact-in-expectation renderers share one optical model (the ray-traced relay of
:mod:`~sassi_bench.optics.relay`, as built: :func:`~sassi_bench.rig.sim.geometry.bench_relay`;
and the spot width of :func:`~sassi_bench.optics.psf.line_spread_sigma`):

* **dense** (:meth:`SpectralRenderer.render_dense`), for patterns with many open
  pixels: for every wavelength sample the SLM image is warped onto the camera through
  the inverse relay map (solved to 1e-7 px on a coarse grid and interpolated bilinearly,
  from nodes moved so that the interpolant has no mean offset where the map curves:
  :func:`_interpolation_nodes`), scaled by the local area ratio so energy is conserved,
  and blurred. Bilinear warping already spreads a pixel like a tent of one SLM pixel,
  so the blur adds only the variance still missing. Only the camera rows the SLM's
  light can reach (the coarse map says which, exactly: a bilinear interpolant stays
  within its nodes' range) are warped and blurred; the others stay 0. The full-size
  maps of those rows are interpolated by a compiled loop
  (:mod:`~sassi_bench.rig.sim._warp`) and kept for a laser's few samples.
* **sparse** (:meth:`SpectralRenderer.render_sparse`), for pinholes and adaptive masks:
  every open pixel's streak is splatted as a sum over wavelength samples of separable
  spots (tabulated profiles) placed at the ray-traced positions, by a compiled loop
  (:mod:`~sassi_bench.rig.sim._splat`).

Both return the photo-electron rate (e-/s) per camera pixel; noise is added by the
sensor model. No Python loop runs over pixels: loops run over wavelength samples
(dense) or in compiled code (sparse).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import cv2
import numpy as np
from numpy.typing import NDArray

from sassi_bench.optics.psf import PsfSigmaCurve, line_spread_sigma
from sassi_bench.optics.relay import SpectralRelay
from sassi_bench.optics.sources import SpectralSamples
from sassi_bench.rig.sim._splat import PAD, splat, table_width
from sassi_bench.rig.sim._warp import label_image, upsample_maps
from sassi_bench.rig.sim.scenes import LabelScene, Scene, interpolate_rows

__all__ = ["SpectralRenderer", "discrete_gaussian_kernel", "spot_profile"]

_TRUNCATE_SIGMAS = 4.0
# Samples per camera pixel of the tabulated spot profiles.
_TABLE_STEPS = 64
# Coarse inverse maps kept (three small float32 grids each, 0.8 MB at the prototype's
# scale): every sample of the lights a calibration uses.
_KEPT_MAPS = 1024
# A light with at most this many samples (a laser line) keeps its full-resolution maps
# of the rows reached between dense frames (three float32 bands of rows per sample).
_CACHED_SAMPLES = 8
# The inverse map's fixed-point iteration: tolerance (camera px) and iteration limit.
_MAP_TOL_PX = 1e-7
#: The SLM coordinate given to camera points no ray reaches: far outside any SLM.
_UNREACHED = -1.0e6
_MAP_ITERATIONS = 40


def _interpolation_nodes(grid: NDArray[np.float64]) -> NDArray[np.float64]:
    """Node values whose bilinear interpolant matches a smooth map on average over each cell.

    Inside a cell of side ``h`` the bilinear interpolant of a curved map ``f`` is off by
    ``t (1 - t) h² f'' / 2`` along each axis, ``h² f'' / 12`` on average, and to one side
    wherever the curvature keeps its sign (the relay's distortion, the prism's bend), so
    every dense frame sat off the ray trace by that mean
    (``docs/notes/2026-12-01-lamp-rigs-red-end.md``). Each node moved by ``-Δ²f / 12``
    along each axis removes it; nodes beside an untraced (NaN) one stay.

    Examples
    --------
    >>> x = np.arange(5.0)
    >>> nodes = _interpolation_nodes(np.add.outer(0.0 * x, x**2))  # f = x², cells of 1
    >>> float(nodes[2, 2])  # 4 - 2/12: the cell means of the interpolant are those of x²
    3.8333333333333335
    """
    out = np.array(grid, dtype=np.float64)
    for axis in (0, 1):
        inner = [slice(None)] * 2
        inner[axis] = slice(1, -1)
        second = np.diff(grid, n=2, axis=axis)
        out[tuple(inner)] -= np.nan_to_num(second, nan=0.0) / 12.0
    return out


def spot_profile(
    offset: NDArray[np.float64], half_width: float, sigma: float
) -> NDArray[np.float64]:
    """1-D profile of one SLM pixel's image: a tent convolved with a Gaussian.

    A square SLM pixel imaged onto square camera pixels of about the same size gives a
    box convolved with a box, a tent of half-width ``half_width`` (one SLM pitch in
    camera px); the optics add a Gaussian of ``sigma``. Bilinear warping produces the
    same tent, which is why the dense and sparse renderers agree.

    Parameters
    ----------
    offset
        Distances (camera px) from the spot centre.
    half_width, sigma
        Tent half-width and Gaussian sigma (camera px); sigma may be 0.

    Returns
    -------
    ndarray
        Profile values (it integrates to 1 over ``offset``).

    Examples
    --------
    >>> x = np.linspace(-6, 6, 12001)
    >>> round(float(np.trapezoid(spot_profile(x, 1.0, 0.5), x)), 6)
    1.0
    """
    from scipy.special import ndtr

    x = np.asarray(offset, dtype=np.float64)
    a = float(half_width)
    if sigma < 1e-3:
        return np.clip(1.0 - np.abs(x) / a, 0.0, None) / a

    def ramp(t: NDArray[np.float64]) -> NDArray[np.float64]:
        # Integral of Phi: the Gaussian-smoothed version of max(t, 0).
        z = t / sigma
        return t * ndtr(z) + sigma * np.exp(-0.5 * z**2) / np.sqrt(2.0 * np.pi)

    return (ramp(x + a) - 2.0 * ramp(x) + ramp(x - a)) / a**2


def discrete_gaussian_kernel(sigma: float) -> NDArray[np.float32]:
    """A normalised, sampled Gaussian kernel whose *discrete* variance is ``sigma**2``.

    A Gaussian sampled at integers with sigma below about 0.7 px has a visibly smaller
    variance than intended (OpenCV's ``GaussianBlur`` included); the kernel's width
    parameter is solved so the sampled kernel spreads light by exactly ``sigma``.

    Examples
    --------
    >>> k = discrete_gaussian_kernel(0.4)
    >>> j = np.arange(k.size) - k.size // 2
    >>> round(float(np.sum(j**2 * k)), 6)
    0.16
    """
    from scipy.optimize import brentq

    taps = max(1, int(np.ceil(4.0 * sigma)))
    j = np.arange(-taps, taps + 1, dtype=np.float64)

    def kernel(width: float) -> NDArray[np.float64]:
        k = np.exp(-0.5 * (j / width) ** 2)
        return k / k.sum()

    if sigma < 0.8:
        width = brentq(lambda w: float(np.sum(j**2 * kernel(w))) - sigma**2, 1e-3, 2.0 * sigma)
    else:
        width = sigma
    return kernel(width).astype(np.float32)


@lru_cache(maxsize=4096)
def _blur_kernel(sigma: float) -> NDArray[np.float32]:
    """:func:`discrete_gaussian_kernel`, solved once per sigma (read-only)."""
    kernel = discrete_gaussian_kernel(sigma)
    kernel.setflags(write=False)
    return kernel


@dataclass(frozen=True)
class _SpotTable:
    """Spot profiles of a set of wavelength samples, for the sparse renderer.

    ``taps[k, phase, PAD + t]`` is sample k's profile at whole-pixel offset
    ``t - reach[k] - phase / _TABLE_STEPS`` px from the spot's centre (zero beyond
    ``reach[k]`` px), normalised to sum to 1 over ``t`` in ``0 .. 2 reach[k]`` for every
    phase; every other entry is 0 (the layout of :mod:`~sassi_bench.rig.sim._splat`).
    """

    taps: NDArray[np.float32]
    reach: NDArray[np.int64]


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
    """

    def __init__(
        self,
        relay: SpectralRelay,
        blur: PsfSigmaCurve,
        fill_factor: float,
        quantum_efficiency,
        coarse_step: int = 8,
    ) -> None:
        self.relay = relay
        self.blur = blur
        self.fill_factor = fill_factor
        self.quantum_efficiency = quantum_efficiency
        hc, wc = relay.camera_shape
        self.camera_shape = (hc, wc)
        step = float(coarse_step)
        self._step = step
        self._coarse_x = np.arange(-step, wc + step, step)
        self._coarse_y = np.arange(-step, hc + step, step)
        self._inverse_cache: dict[float, tuple[NDArray[np.float32], ...]] = {}
        self._reference_map: tuple[NDArray[np.float64], ...] | None = None
        self._labels: tuple[LabelScene, NDArray[np.int32]] | None = None
        self._dense_cache: dict[tuple[float, int, int], tuple[NDArray[np.float32], ...]] = {}
        self._tables: dict[tuple[float, ...], _SpotTable] = {}

    def use_relay(self, relay: SpectralRelay) -> None:
        """Render through ``relay`` from now on (a drifted bench), dropping what was
        cached for the previous one."""
        self.relay = relay
        self._inverse_cache.clear()
        self._dense_cache.clear()
        self._reference_map = None

    # -- the optical model shared by both renderers ---------------------------------
    def spot_sigma(self, wavelength_nm: NDArray[np.float64]) -> NDArray[np.float64]:
        """Sigma (camera px) of the spot one SLM pixel makes, at each wavelength."""
        return line_spread_sigma(self.blur(wavelength_nm), self.relay.scale, self.fill_factor)

    def _tent_blur(self, spot_sigma: NDArray[np.float64]) -> NDArray[np.float64]:
        """Gaussian sigma that, on top of a tent of one SLM pitch, gives ``spot_sigma``.

        A tent of half-width ``scale`` has variance ``scale**2 / 6``.
        """
        scale = self.relay.scale
        return np.sqrt(np.clip(spot_sigma**2 - scale**2 / 6.0, 0.0, None))

    def _spot_table(self, wavelengths_nm: NDArray[np.float64]) -> _SpotTable:
        """Tabulated spot profiles of these samples (cached; see :class:`_SpotTable`)."""
        key = tuple(np.round(wavelengths_nm, 6))
        table = self._tables.get(key)
        if table is None:
            spot = self.spot_sigma(wavelengths_nm)
            sigma = self._tent_blur(spot)
            scale = self.relay.scale
            reach = np.ceil(_TRUNCATE_SIGMAS * spot + scale).astype(np.int64) + 1
            # Zeros around the taps (the splat's layout: see its table_width).
            width = table_width(int(reach.max()))
            phase = np.arange(_TABLE_STEPS)[:, None] / _TABLE_STEPS
            taps = np.zeros((wavelengths_nm.size, _TABLE_STEPS, width))
            for k, (r, sd) in enumerate(zip(reach, sigma, strict=True)):
                offsets = np.arange(2 * r + 1)[None, :] - r - phase
                values = spot_profile(offsets, scale, sd)
                values[np.abs(offsets) > r] = 0.0
                taps[k, :, PAD : PAD + 2 * r + 1] = values / values.sum(axis=1, keepdims=True)
            table = _SpotTable(taps=taps.astype(np.float32), reach=reach)
            self._tables[key] = table
        return table

    def _dense_blurs(
        self, wavelengths_nm: NDArray[np.float64], gain: NDArray[np.float64]
    ) -> list[tuple[list[int], int, NDArray[np.float32] | None]]:
        """The dense renderer's blurs: runs of lit samples (``gain > 0``) blurred together,
        each with the rows its blur reaches and its kernel (a separable 1-D kernel, or
        None where the warp's tent is blur enough). Here every lit sample is a run of its
        own."""
        extra = self._tent_blur(self.spot_sigma(wavelengths_nm))
        return [
            ([k], int(np.ceil(4.0 * s)), _blur_kernel(float(s)) if s > 0.05 else None)
            for k, s in enumerate(extra)
            if gain[k] > 0
        ]

    def electrons_per_photon(self, samples: SpectralSamples) -> NDArray[np.float64]:
        """Photo-electron rate each sample delivers per unit reflectance and transmission."""
        return samples.weights * self.quantum_efficiency(samples.wavelengths_nm)

    # -- dense ----------------------------------------------------------------------
    def _reference(self) -> tuple[NDArray[np.float64], ...]:
        """The coarse inverse map at the relay's reference wavelength (Newton's method,
        :meth:`SpectralRelay.inverse`) and its Jacobian d(u, v)/d(x, y): the start and
        the fixed step of every other wavelength's solve (see :meth:`_inverse_maps`)."""
        if self._reference_map is None:
            gx, gy = np.meshgrid(self._coarse_x, self._coarse_y)
            lam = float(self.relay.reference_nm)
            u, v = self.relay.inverse(gx, gy, lam)
            du_dy, du_dx = np.gradient(u, self._step)
            dv_dy, dv_dx = np.gradient(v, self._step)
            centre = self._centre_inverse(lam)
            self._reference_map = (gx, gy, u, v, du_dx, du_dy, dv_dx, dv_dy, *centre)
        return self._reference_map

    def _centre_inverse(self, wavelength_nm: float) -> tuple[float, float]:
        """The SLM point imaged at the camera's centre at one wavelength."""
        hc, wc = self.camera_shape
        u, v = self.relay.inverse(
            np.array([(wc - 1) / 2.0]), np.array([(hc - 1) / 2.0]), wavelength_nm
        )
        return float(u[0]), float(v[0])

    def _inverse_maps(self, wavelength_nm: float) -> tuple[NDArray[np.float32], ...]:
        """Coarse inverse map (u, v) and area ratio |d(u,v)/d(x,y)| at one wavelength.

        Solved to :data:`_MAP_TOL_PX` by a fixed-point (chord) iteration: it starts from
        the reference wavelength's map moved by the shift of the camera centre's SLM
        point, and steps by the reference map's Jacobian, one ray trace per step (about
        four steps, against Newton's four steps of three traces each). The start depends
        on the wavelength alone, so the map does not depend on what was rendered before
        (a resumed capture renders the same frames). Newton's method is the fallback.
        """
        key = round(float(wavelength_nm), 6)
        cached = self._inverse_cache.get(key)
        if cached is not None:
            return cached
        gx, gy, u_ref, v_ref, du_dx, du_dy, dv_dx, dv_dy, cu_ref, cv_ref = self._reference()
        cu, cv = self._centre_inverse(key)
        u, v = u_ref + (cu - cu_ref), v_ref + (cv - cv_ref)
        for _ in range(_MAP_ITERATIONS):
            fx, fy = self.relay.forward(u, v, key)
            rx, ry = gx - fx, gy - fy
            u += du_dx * rx + du_dy * ry
            v += dv_dx * rx + dv_dy * ry
            if np.nanmax(np.abs(rx) + np.abs(ry), initial=0.0) < _MAP_TOL_PX:
                break
        else:
            u, v = self.relay.inverse(gx, gy, key)
        step = self._step
        grad_u = np.gradient(u, step)
        grad_v = np.gradient(v, step)
        area = np.abs(grad_u[1] * grad_v[0] - grad_u[0] * grad_v[1])
        u, v = _interpolation_nodes(u), _interpolation_nodes(v)
        # Camera points no ray from the SLM side reaches (far off the SLM's image, past
        # what the prism passes) have no inverse: they get no light.
        traced = np.isfinite(u) & np.isfinite(v)
        u, v = np.where(traced, u, _UNREACHED), np.where(traced, v, _UNREACHED)
        area = np.where(np.isfinite(area), area, 0.0)
        maps = (u.astype(np.float32), v.astype(np.float32), area.astype(np.float32))
        if len(self._inverse_cache) >= _KEPT_MAPS:
            self._inverse_cache.clear()
        self._inverse_cache[key] = maps
        return maps

    def _reached_rows(
        self, maps: tuple[NDArray[np.float32], ...], slm_shape: tuple[int, int]
    ) -> tuple[int, int]:
        """Camera rows [first, stop) where the warped SLM image can be non-zero.

        A coarse cell's bilinear map stays within the range of its four nodes, so a cell
        can sample the SLM (bilinearly: any point within a pixel of it) only if that
        range overlaps it.
        """
        u, v = maps[0], maps[1]
        h, w = slm_shape

        def cell_max(m: NDArray[np.float32]) -> NDArray[np.float32]:
            return np.maximum(
                np.maximum(m[:-1, :-1], m[:-1, 1:]), np.maximum(m[1:, :-1], m[1:, 1:])
            )

        def cell_min(m: NDArray[np.float32]) -> NDArray[np.float32]:
            return np.minimum(
                np.minimum(m[:-1, :-1], m[:-1, 1:]), np.minimum(m[1:, :-1], m[1:, 1:])
            )

        inside = (cell_max(u) > -1) & (cell_min(u) < w) & (cell_max(v) > -1) & (cell_min(v) < h)
        cells = np.flatnonzero(inside.any(axis=1))
        if cells.size == 0:
            return 0, 0
        first = int(np.floor(self._coarse_y[cells[0]]))
        stop = int(np.ceil(self._coarse_y[cells[-1] + 1])) + 1
        return max(first, 0), min(stop, self.camera_shape[0])

    def _dense_maps(
        self, wavelength_nm: float, first: int, stop: int, keep: bool
    ) -> tuple[NDArray[np.float32], ...]:
        """Full-resolution inverse map (u, v) and area ratio of camera rows [first, stop).

        With ``keep`` the maps are kept (a sweep renders the same laser frame after frame).
        """
        key = (round(float(wavelength_nm), 6), first, stop)
        maps = self._dense_cache.get(key)
        if maps is None:
            shape = (stop - first, self.camera_shape[1])
            maps = tuple(np.empty(shape, np.float32) for _ in range(3))
            upsample_maps(*self._inverse_maps(wavelength_nm), self._step, first, *maps)
            if keep:
                self._dense_cache[key] = maps
        return maps

    def _slm_labels(self, scene: LabelScene, slm_shape: tuple[int, int]) -> NDArray[np.int32]:
        """The label image of the SLM's window of ``scene`` (int32, kept for the last scene)."""
        if self._labels is None or self._labels[0] is not scene:
            rows, cols = scene.slm_window(slm_shape)
            self._labels = (scene, np.ascontiguousarray(scene.labels[rows, cols], np.int32))
        return self._labels[1]

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
        rate = np.zeros(self.camera_shape, dtype=np.float32)
        gain = self.electrons_per_photon(samples)
        blurs = self._dense_blurs(samples.wavelengths_nm, gain)
        lit = [k for members, _, _ in blurs for k in members]
        if not lit:
            return rate
        maps = {k: self._inverse_maps(samples.wavelengths_nm[k]) for k in lit}
        # One band of rows for every sample: those any sample reaches, plus the widest blur.
        reach = [self._reached_rows(maps[k], transmission.shape) for k in lit]
        reach = [r for r in reach if r[1] > r[0]]
        if not reach:
            return rate
        taps = max(blur_rows for _, blur_rows, _ in blurs) + 1
        first = max(0, min(r[0] for r in reach) - taps)
        stop = min(self.camera_shape[0], max(r[1] for r in reach) + taps)
        transmission = np.ascontiguousarray(transmission, dtype=np.float32)
        labelled = isinstance(scene, LabelScene)
        if labelled:
            labels = self._slm_labels(scene, transmission.shape)
            per_label = interpolate_rows(
                scene.spectra, scene.wavelengths_nm, samples.wavelengths_nm
            ).astype(np.float32)
        keep = samples.wavelengths_nm.size <= _CACHED_SAMPLES
        wanted = {(round(float(samples.wavelengths_nm[k]), 6), first, stop) for k in lit}
        if not keep or not wanted.issuperset(self._dense_cache):
            self._dense_cache.clear()
        source = np.empty_like(transmission)
        band = np.empty((stop - first, self.camera_shape[1]), np.float32)
        blurred = np.empty_like(band)
        summed = np.empty_like(band) if any(len(run) > 1 for run, _, _ in blurs) else None
        lit_rows = rate[first:stop]
        for members, _, kernel in blurs:
            for n, k in enumerate(members):
                lam = samples.wavelengths_nm[k]
                if labelled:
                    label_image(transmission, labels, np.ascontiguousarray(per_label[:, k]), source)
                else:
                    source = transmission * scene.reflectance_image(lam)[rows, cols]
                map_u, map_v, area = self._dense_maps(lam, first, stop, keep)
                cv2.remap(
                    source,
                    map_u,
                    map_v,
                    dst=band,
                    interpolation=cv2.INTER_LINEAR,
                    borderMode=cv2.BORDER_CONSTANT,
                    borderValue=0.0,
                )
                cv2.multiply(band, area, dst=band, scale=float(gain[k]))
                if len(members) > 1 and n == 0:
                    np.copyto(summed, band)
                elif len(members) > 1:
                    np.add(summed, band, out=summed)
            image = band if len(members) == 1 else summed
            if kernel is None:
                np.add(lit_rows, image, out=lit_rows)
                continue
            if kernel.ndim == 1:
                cv2.sepFilter2D(
                    image, -1, kernel, kernel, dst=blurred, borderType=cv2.BORDER_CONSTANT
                )
            else:  # a correlated spot: its 2-D kernel (point-symmetric, so no flip)
                cv2.filter2D(image, -1, kernel, dst=blurred, borderType=cv2.BORDER_CONSTANT)
            np.add(lit_rows, blurred, out=lit_rows)
        return rate

    # -- sparse ---------------------------------------------------------------------
    def render_sparse(
        self,
        rows: NDArray[np.intp],
        cols: NDArray[np.intp],
        transmission: NDArray[np.float32],
        scene: Scene,
        samples: SpectralSamples,
        base: NDArray[np.float32] | None = None,
    ) -> NDArray[np.float32]:
        """Electron rate for a few open SLM pixels, by splatting their streaks.

        Every (pixel, sample) spot is the tabulated profile (1/64 px steps, nearest
        entry) in x times that in y, each normalised over its whole-pixel taps, so every
        sample deposits exactly its energy.

        Parameters
        ----------
        rows, cols
            SLM coordinates of the open pixels (N,).
        transmission
            Their transmissions (N,).
        base
            A rate the streaks are added onto (a copy of it is returned); default 0.

        Examples
        --------
        >>> from sassi_bench import open_rig
        >>> from sassi_bench.rig.sim import truth
        >>> bench = truth(open_rig("sim")).bench
        >>> lit = np.array([200]), np.array([320])
        >>> rate = bench.renderer.render_sparse(
        ...     *lit, np.ones(1, np.float32), bench.scene, bench.samples("laser:532")
        ... )
        >>> rate.shape, bool(rate.sum() > 0)
        ((512, 800), True)
        """
        if base is None:
            total = np.zeros(self.camera_shape, dtype=np.float32)
        else:
            total = np.array(base, dtype=np.float32, copy=True)
        if rows.size == 0:
            return total
        lam = samples.wavelengths_nm
        gain = self.electrons_per_photon(samples).astype(np.float32)
        table = self._spot_table(lam)
        spectra = scene.reflectance_at(rows + scene.margin, cols + scene.margin, lam)
        spectra *= gain[None, :] * np.asarray(transmission, dtype=np.float32)[:, None]
        x, y = self.relay.forward_grid(cols, rows, lam)
        splat(x, y, spectra, table.taps, table.reach, _TABLE_STEPS, total)
        return total
