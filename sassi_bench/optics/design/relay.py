"""A traced design as the SLM -> camera map and spot of every SLM point and wavelength.

:class:`DesignRelay` answers what :class:`~sassi_bench.optics.relay.SpectralRelay` answers
(``forward``, ``forward_grid``, ``inverse``, ``scale``, the shapes and the reference
wavelength), from smooth interpolants of a traced grid
(:class:`~sassi_bench.optics.design.interp.GridSpline`), and adds what a parametric relay
cannot: the spot's covariance and the throughput at every SLM point and wavelength.

Positions are spot centroids, not chief rays: elliptical, tilted spots put their centroid
up to half a pixel from the chief ray on the shipped designs, and what a camera measures
is the centroid. The spot's covariance is the moment-matched Gaussian of the optics: the
traced geometric covariance plus the diffraction core, ``(0.42 lambda N)**2`` on each axis
with ``N = 1 / (2 NA)`` the image-side working F-number.

Examples
--------
>>> import numpy as np
>>> from sassi_bench.optics.design.trace import TracedGrid
>>> u, v, lam = np.linspace(-10, 650, 5), np.linspace(-10, 410, 4), np.linspace(380, 730, 8)
>>> U, V, L = np.meshgrid(u, v, lam, indexing="ij")
>>> x = 50 + 0.9 * U + 0.4 * (L - 380)
>>> y = 60 + 0.9 * V
>>> ones = np.ones_like(U)
>>> grid = TracedGrid(u, v, lam, x, y, x, y, ones, ones, 0 * ones, ones, image_na=0.06)
>>> relay = DesignRelay(grid, (400, 640), (512, 800), 5.5, 550.0)
>>> round(relay.scale, 6)
0.9
>>> uu, vv = relay.inverse(*relay.forward(100.0, 50.0, 500.0), 500.0)
>>> round(float(uu), 6), round(float(vv), 6)
(100.0, 50.0)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.optics.design.interp import GridSpline
from sassi_bench.optics.design.trace import TracedGrid

__all__ = ["DIFFRACTION_SIGMA_PER_LAMBDA_N", "DesignRelay"]

#: Sigma of the Gaussian that best matches an Airy core, in units of lambda * N.
DIFFRACTION_SIGMA_PER_LAMBDA_N = 0.42

_POSITIONS = ("x", "y")
_MOMENTS = ("sxx", "syy", "sxy")


class DesignRelay:
    """A traced design's SLM -> camera map, spots and throughput.

    Parameters
    ----------
    grid
        The design traced on a grid (:func:`~sassi_bench.optics.design.cache.cached_trace`).
    slm_shape, camera_shape
        (height, width) of the SLM and the camera.
    camera_pixel_pitch_um
        The camera's pixel pitch (the diffraction core's width in pixels).
    reference_nm
        The design's reference wavelength.
    """

    def __init__(
        self,
        grid: TracedGrid,
        slm_shape: tuple[int, int],
        camera_shape: tuple[int, int],
        camera_pixel_pitch_um: float,
        reference_nm: float,
    ) -> None:
        self.grid = grid
        self.slm_shape = slm_shape
        self.camera_shape = camera_shape
        self.reference_nm = float(reference_nm)
        self.camera_pixel_pitch_um = float(camera_pixel_pitch_um)
        self.image_na = float(grid.image_na)
        values = {name: getattr(grid, name) for name in (*_POSITIONS, *_MOMENTS, "throughput")}
        self.spline = GridSpline(grid.u, grid.v, grid.wavelengths_nm, values)
        h, w = slm_shape
        self.slm_centre = ((w - 1) / 2.0, (h - 1) / 2.0)
        jac = self._jacobian(
            np.array(self.slm_centre[0]), np.array(self.slm_centre[1]), self.reference_nm
        )
        #: Camera pixels per SLM pixel at the field centre (square root of the local area ratio).
        self.scale = float(np.sqrt(abs(jac[0] * jac[3] - jac[1] * jac[2])))

    # -- positions ---------------------------------------------------------------------
    def forward(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera centroid (x, y) of SLM pixel (u, v) at a wavelength (broadcasting)."""
        return self.spline.points(_POSITIONS, u, v, wavelength_nm)

    def forward_grid(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera centroids of SLM points (u[i], v[i]) at every wavelength[k]: (P, K)."""
        out = self.spline.grid(_POSITIONS, u, v, wavelength_nm)
        return out[..., 0], out[..., 1]

    def _jacobian(self, u: NDArray, v: NDArray, wavelength_nm: float, h: float = 0.5):
        x0, y0 = self.forward(u - h, v, wavelength_nm)
        x1, y1 = self.forward(u + h, v, wavelength_nm)
        x2, y2 = self.forward(u, v - h, wavelength_nm)
        x3, y3 = self.forward(u, v + h, wavelength_nm)
        return (x1 - x0) / (2 * h), (x3 - x2) / (2 * h), (y1 - y0) / (2 * h), (y3 - y2) / (2 * h)

    def inverse(
        self,
        x: ArrayLike,
        y: ArrayLike,
        wavelength_nm: float,
        tol_px: float = 1e-7,
        max_iter: int = 40,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """SLM position (u, v) whose spot centroid lands at camera (x, y) at one wavelength.

        Newton's method with the interpolant's Jacobian, from the inverse of the map's
        affine fit at that wavelength; vectorised over points.
        """
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        # Affine start: the map at three points around the centre.
        cu, cv = self.slm_centre
        xc, yc = self.forward(cu, cv, wavelength_nm)
        a, b, c, d = (
            float(j) for j in self._jacobian(np.array(cu), np.array(cv), wavelength_nm, 20.0)
        )
        det = a * d - b * c
        dx, dy = x - xc, y - yc
        u = cu + (d * dx - b * dy) / det
        v = cv + (-c * dx + a * dy) / det
        for _ in range(max_iter):
            fx, fy = self.forward(u, v, wavelength_nm)
            rx, ry = x - fx, y - fy
            a, b, c, d = self._jacobian(u, v, wavelength_nm)
            det = a * d - b * c
            u = u + (d * rx - b * ry) / det
            v = v + (-c * rx + a * ry) / det
            if np.nanmax(np.abs(rx) + np.abs(ry), initial=0.0) < tol_px:
                break
        return u, v

    # -- spots ---------------------------------------------------------------------------
    def diffraction_variance(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """Variance (camera px**2, each axis) of the diffraction core at a wavelength."""
        n_working = 1.0 / (2.0 * self.image_na)
        lam_um = np.asarray(wavelength_nm, dtype=np.float64) * 1e-3
        sigma = DIFFRACTION_SIGMA_PER_LAMBDA_N * lam_um * n_working / self.camera_pixel_pitch_um
        return sigma**2

    def optics_covariance(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The optics' spot covariance (sxx, syy, sxy; camera px**2) at (u, v, wavelength),
        broadcast: the traced geometric moments plus the diffraction core."""
        sxx, syy, sxy = self.spline.points(_MOMENTS, u, v, wavelength_nm)
        core = self.diffraction_variance(np.broadcast_to(wavelength_nm, sxx.shape))
        return np.maximum(sxx, 0.0) + core, np.maximum(syy, 0.0) + core, sxy

    def optics_covariance_grid(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """:meth:`optics_covariance` of points (u[i], v[i]) at every wavelength: (P, K)."""
        out = self.spline.grid(_MOMENTS, u, v, wavelength_nm)
        core = self.diffraction_variance(np.asarray(wavelength_nm, dtype=np.float64).ravel())
        return np.maximum(out[..., 0], 0.0) + core, np.maximum(out[..., 1], 0.0) + core, out[..., 2]

    def spots_grid(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], ...]:
        """Centroids, optics covariance and throughput of points (u[i], v[i]) at every
        wavelength in one pass over the interpolants: (x, y, cxx, cyy, cxy, throughput),
        each (P, K)."""
        names = (*_POSITIONS, *_MOMENTS, "throughput")
        out = self.spline.grid(names, u, v, wavelength_nm)
        core = self.diffraction_variance(np.asarray(wavelength_nm, dtype=np.float64).ravel())
        x, y, sxx, syy, sxy, throughput = (out[..., i] for i in range(len(names)))
        return (
            x,
            y,
            np.maximum(sxx, 0.0) + core,
            np.maximum(syy, 0.0) + core,
            sxy,
            np.clip(throughput, 0.0, 1.0),
        )

    def throughput(self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike) -> NDArray:
        """Share of the pupil that reaches the camera (1: no vignetting), broadcast."""
        return np.clip(self.spline.at("throughput", u, v, wavelength_nm), 0.0, 1.0)

    def throughput_grid(self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike) -> NDArray:
        """:meth:`throughput` of points (u[i], v[i]) at every wavelength: (P, K)."""
        return np.clip(self.spline.grid(("throughput",), u, v, wavelength_nm)[..., 0], 0.0, 1.0)

    def widest_sigma(self, wavelength_nm: ArrayLike) -> NDArray[np.float64]:
        """The optics' widest spot sigma over the SLM (major axis, camera px) per wavelength."""
        lam = np.atleast_1d(np.asarray(wavelength_nm, dtype=np.float64))
        h, w = self.slm_shape
        u, v = np.meshgrid(np.linspace(0, w - 1, 17), np.linspace(0, h - 1, 11))
        sxx, syy, sxy = self.optics_covariance_grid(u.ravel(), v.ravel(), lam)
        major = 0.5 * (sxx + syy) + np.sqrt(0.25 * (sxx - syy) ** 2 + sxy**2)
        return np.sqrt(major.max(axis=0))
