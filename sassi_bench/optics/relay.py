"""Where light from an SLM pixel lands on the spectral camera, from first principles.

The SLM -> camera map of a relay is a ray trace, not a fitted polynomial:

1. SLM pixel (u, v), relative to the SLM centre and rotated by ``rotation_deg`` (the
   SLM's mounting error), becomes a collimated beam whose direction is set by the
   collimating lens (focal length ``f1``, in SLM pixels).
2. The beam crosses the prism (apex angle, incidence, Sellmeier index of the glass),
   traced exactly in 3-D with Snell's law, so field-dependent dispersion, anamorphic
   magnification and the curvature of spectral lines of skew rays all come out of the
   physics.
3. The camera lens (focal length ``f2`` in camera pixels, axis along the deviated
   reference ray) focuses it; ``f2`` is chosen so the 400-700 nm streak at the field
   centre is ``spread_px`` long, and ``f2 / f1 = scale``.
4. The prism sits slightly rolled about the optical axis, so a streak is not quite
   horizontal: its 700 nm end lies ``smile_px`` rows below its 400 nm end at the field
   centre (the roll angle is solved for). With the skew-ray curvature this gives the
   small wavelength-dependent row shift that the calibration fits.
5. Mild radial distortion ``distortion_k1`` (radius normalised to the camera's half
   diagonal).

A relay is aligned for the prism it is built with: the focal length, the prism's roll
and its incidence angle are solved with that glass and apex. :meth:`SpectralRelay.with_prism`
puts another prism into the aligned relay (another melt, a prism ground to another
angle) and points the camera where the new prism's reference ray goes (a lab aligns its
camera on the light), so its streaks differ in length, shape and position from what the
aligned design predicts.
"""

from __future__ import annotations

import copy

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError, step_error
from sassi_bench.optics.glass import Glass
from sassi_bench.optics.prism import (
    face_normals,
    min_deviation_incidence_deg,
    rotation_about_y,
    trace_prism,
)

__all__ = ["BAND_NM", "SpectralRelay"]

#: The band whose streak length (``spread_px``) and row drift (``smile_px``) are described.
BAND_NM = (400.0, 700.0)
# From this many rays on, :meth:`SpectralRelay.forward` runs the compiled trace (fewer
# stay in numpy, so a process that traces a few rays does not compile it).
_COMPILED_MIN_RAYS = 4096


class SpectralRelay:
    """The SLM -> collimator -> prism -> camera lens optics, traced ray by ray.

    Parameters
    ----------
    slm_shape, camera_shape
        (height, width) of the SLM and of the spectral camera.
    scale
        Camera pixels per SLM pixel (``f2 / f1``).
    rotation_deg
        Rotation of the SLM about the optical axis.
    offset_px
        Optical centre on the camera, (x, y) from the camera's centre.
    distortion_k1
        Radial distortion, radius normalised to the camera's half diagonal.
    glass
        The prism's glass.
    apex_deg
        The prism's apex angle.
    spread_px
        Length of the 400-700 nm streak at the field centre, camera px.
    smile_px
        Rows the streak's 700 nm end lies below its 400 nm end at the field centre.
    incidence_deg
        Incidence of the central ray on the prism; None: minimum deviation at
        ``reference_nm``.
    reference_nm
        Wavelength whose central ray defines the camera axis.

    Examples
    --------
    >>> from sassi_bench.optics.glass import get_glass
    >>> relay = SpectralRelay((400, 640), (512, 800), scale=1.08, rotation_deg=0.5,
    ...                       offset_px=(14.0, 3.0), distortion_k1=0.002,
    ...                       glass=get_glass("N-BK7"), apex_deg=30.0, spread_px=68.0,
    ...                       smile_px=1.0)
    >>> x, y = relay.forward([319.5, 319.5], [199.5, 199.5], [400.0, 700.0])
    >>> round(float(x[1] - x[0]), 6), round(float(y[1] - y[0]), 6)
    (68.0, 1.0)
    """

    def __init__(
        self,
        slm_shape: tuple[int, int],
        camera_shape: tuple[int, int],
        *,
        scale: float,
        rotation_deg: float,
        offset_px: tuple[float, float],
        distortion_k1: float,
        glass: Glass,
        apex_deg: float,
        spread_px: float,
        smile_px: float,
        incidence_deg: float | None = None,
        reference_nm: float = 550.0,
    ) -> None:
        self.slm_shape = slm_shape
        self.camera_shape = camera_shape
        self.scale = scale
        self.rotation_deg = rotation_deg
        self.distortion_k1 = distortion_k1
        self.reference_nm = reference_nm
        self.glass = glass
        self.apex_deg = float(apex_deg)
        h, w = slm_shape
        hc, wc = camera_shape
        self.slm_centre = ((w - 1) / 2.0, (h - 1) / 2.0)
        self.optical_centre = ((wc - 1) / 2.0 + offset_px[0], (hc - 1) / 2.0 + offset_px[1])
        self.distortion_radius = 0.5 * float(np.hypot(wc, hc))
        n_ref = float(self.glass.index(reference_nm))
        self.incidence_deg = (
            incidence_deg
            if incidence_deg is not None
            else min_deviation_incidence_deg(n_ref, apex_deg)
        )
        # Solve the camera focal length (streak length = spread_px) and the prism roll
        # (end-to-end row offset = smile_px) at the field centre by fixed-point iteration.
        self.f2, self.roll_rad = 1000.0, 0.0
        for _ in range(8):
            self._to_camera = self._align_camera(n_ref)
            x, y = self.forward(
                [self.slm_centre[0]] * 2, [self.slm_centre[1]] * 2, np.array(BAND_NM)
            )
            self.f2 *= spread_px / float(x[1] - x[0])
            self.roll_rad += np.arctan2(smile_px - float(y[1] - y[0]), float(x[1] - x[0]))

    def with_prism(self, glass: Glass, apex_deg: float) -> SpectralRelay:
        """This relay, as aligned, with another prism in place.

        The focal lengths, the prism's roll and its incidence angle stay as solved for
        this relay's prism; the camera is pointed where the new prism's reference ray goes.

        Parameters
        ----------
        glass, apex_deg
            The prism put in place.

        Returns
        -------
        SpectralRelay
            A new relay; this one is unchanged.

        Examples
        --------
        >>> from sassi_bench.optics.glass import get_glass
        >>> relay = SpectralRelay((400, 640), (512, 800), scale=1.08, rotation_deg=0.0,
        ...                       offset_px=(0.0, 0.0), distortion_k1=0.0,
        ...                       glass=get_glass("N-BK7"), apex_deg=30.0, spread_px=68.0,
        ...                       smile_px=0.0)
        >>> steeper = relay.with_prism(relay.glass, 31.0)
        >>> x, _ = steeper.forward(319.5, 199.5, [400.0, 700.0])
        >>> bool(x[1] - x[0] > 68.0)  # a steeper prism disperses more
        True
        """
        built = copy.copy(self)
        built.glass = glass
        built.apex_deg = float(apex_deg)
        built._to_camera = built._align_camera(float(glass.index(self.reference_nm)))
        return built

    def with_relay(
        self,
        *,
        scale: float | None = None,
        rotation_deg: float | None = None,
        offset_px: tuple[float, float] | None = None,
        distortion_k1: float | None = None,
    ) -> SpectralRelay:
        """This relay, as aligned, with its SLM-side optics built otherwise.

        The camera lens, the prism and its roll stay as solved; ``scale`` changes the
        collimator's focal length (``f1 = f2 / scale``: the SLM's image grows, the streaks
        keep the length the prism and camera lens give them), ``rotation_deg`` the SLM's
        mount, ``offset_px`` where the optical centre lands on the camera, and
        ``distortion_k1`` the lenses' radial distortion. None keeps a value.

        Examples
        --------
        >>> from sassi_bench.optics.glass import get_glass
        >>> relay = SpectralRelay((400, 640), (512, 800), scale=1.08, rotation_deg=0.0,
        ...                       offset_px=(0.0, 0.0), distortion_k1=0.0,
        ...                       glass=get_glass("N-BK7"), apex_deg=30.0, spread_px=68.0,
        ...                       smile_px=0.0)
        >>> x, _ = relay.with_relay(scale=1.1).forward([0.0, 639.0], 199.5, 550.0)
        >>> x0, _ = relay.forward([0.0, 639.0], 199.5, 550.0)
        >>> bool(x[1] - x[0] > x0[1] - x0[0])  # a larger image of the SLM
        True
        """
        built = copy.copy(self)
        if scale is not None:
            built.scale = float(scale)
        if rotation_deg is not None:
            built.rotation_deg = float(rotation_deg)
        if offset_px is not None:
            hc, wc = self.camera_shape
            built.optical_centre = (
                (wc - 1) / 2.0 + float(offset_px[0]),
                (hc - 1) / 2.0 + float(offset_px[1]),
            )
        if distortion_k1 is not None:
            built.distortion_k1 = float(distortion_k1)
        return built

    def _roll(self) -> NDArray[np.float64]:
        """The prism's roll about the optical axis (directions are row vectors)."""
        c, s = np.cos(self.roll_rad), np.sin(self.roll_rad)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])

    def _trace(self, d: NDArray[np.float64], n: ArrayLike) -> NDArray[np.float64]:
        """Trace directions through the rolled prism (roll about the optical axis)."""
        roll = self._roll()
        out = trace_prism(d @ roll, n, self.apex_deg, self.incidence_deg)
        return out @ roll.T

    def _packed(self) -> NDArray[np.float64]:
        """This relay's geometry for the compiled trace (:mod:`._relay_kernels`)."""
        from sassi_bench.optics import _relay_kernels as kernels

        normal1, normal2 = face_normals(self.apex_deg, self.incidence_deg)
        return kernels.pack(
            self.slm_centre,
            self.rotation_deg,
            self.f2 / self.scale,
            self._roll(),
            normal1,
            normal2,
            self._to_camera,
            self.f2,
            self.optical_centre,
            self.distortion_k1 / self.distortion_radius**2,
        )

    def _align_camera(self, n_ref: float) -> NDArray[np.float64]:
        """Rotation taking the deviated central ray at the reference wavelength to +z."""
        axis = self._trace(np.array([0.0, 0.0, 1.0]), n_ref)
        if not np.all(np.isfinite(axis)):
            raise ConfigError(
                step_error(
                    "prism",
                    "the central ray is totally internally reflected",
                    "lower prism.apex_deg or change prism.incidence_deg",
                )
            )
        yaw = rotation_about_y(-np.arctan2(axis[0], axis[2]))
        flat = yaw @ axis
        e = np.arctan2(flat[1], flat[2])
        pitch = np.array(
            [[1.0, 0.0, 0.0], [0.0, np.cos(e), -np.sin(e)], [0.0, np.sin(e), np.cos(e)]]
        )
        return pitch @ yaw

    @property
    def f1(self) -> float:
        """Collimator focal length in SLM pixels."""
        return self.f2 / self.scale

    def forward(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera position of SLM pixel (u, v) at a wavelength (broadcasting).

        Parameters
        ----------
        u, v
            SLM column and row (pixel centres at integers).
        wavelength_nm
            Wavelength(s), broadcast with ``u`` and ``v``.

        Returns
        -------
        x, y : ndarray
            Camera column and row (pixel centres at integers).
        """
        # Field terms depend on (u, v) only and the index on the wavelength only: compute
        # each on its own (unbroadcast) shape and let the ray trace broadcast them.
        u, v = np.broadcast_arrays(np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64))
        n = self.glass.index(np.asarray(wavelength_nm, dtype=np.float64))
        shape = np.broadcast_shapes(u.shape, n.shape)
        if int(np.prod(shape)) >= _COMPILED_MIN_RAYS:
            from sassi_bench.optics import _relay_kernels as kernels

            flat = [np.ascontiguousarray(np.broadcast_to(a, shape)).ravel() for a in (u, v, n)]
            x, y = np.empty(flat[0].size), np.empty(flat[0].size)
            kernels.trace_points(*flat, self._packed(), x, y)
            return x.reshape(shape), y.reshape(shape)
        rot = np.deg2rad(self.rotation_deg)
        du = u - self.slm_centre[0]
        dv = v - self.slm_centre[1]
        hu = np.cos(rot) * du - np.sin(rot) * dv
        hv = np.sin(rot) * du + np.cos(rot) * dv
        d = np.stack([hu, hv, np.full_like(hu, self.f2 / self.scale)], axis=-1)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        out = self._trace(d, n) @ self._to_camera.T
        xu = self.f2 * out[..., 0] / out[..., 2]
        yu = self.f2 * out[..., 1] / out[..., 2]
        factor = 1.0 + self.distortion_k1 * (xu**2 + yu**2) / self.distortion_radius**2
        x = self.optical_centre[0] + xu * factor
        y = self.optical_centre[1] + yu * factor
        return x, y

    def forward_grid(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera positions of SLM points (u[i], v[i]) at every wavelength[k]: (P, K).

        The same trace as :meth:`forward` of ``u[:, None], v[:, None], wavelength[None, :]``
        (compiled, each point's collimated direction made once for all wavelengths).

        Examples
        --------
        >>> from sassi_bench.optics.glass import get_glass
        >>> relay = SpectralRelay((400, 640), (512, 800), scale=1.08, rotation_deg=0.5,
        ...                       offset_px=(14.0, 3.0), distortion_k1=0.002,
        ...                       glass=get_glass("N-BK7"), apex_deg=30.0, spread_px=68.0,
        ...                       smile_px=1.0)
        >>> x, y = relay.forward_grid([319.5], [199.5], [400.0, 700.0])
        >>> x.shape, round(float(x[0, 1] - x[0, 0]), 6)
        ((1, 2), 68.0)
        """
        from sassi_bench.optics import _relay_kernels as kernels

        u = np.ascontiguousarray(u, dtype=np.float64).ravel()
        v = np.ascontiguousarray(v, dtype=np.float64).ravel()
        n = np.ascontiguousarray(self.glass.index(np.asarray(wavelength_nm, dtype=np.float64)))
        n = n.ravel()
        x = np.empty((u.size, n.size))
        y = np.empty((u.size, n.size))
        kernels.trace_grid(u, v, n, self._packed(), x, y)
        return x, y

    def inverse(
        self,
        x: ArrayLike,
        y: ArrayLike,
        wavelength_nm: float,
        tol_px: float = 1e-7,
        max_iter: int = 30,
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """SLM position (u, v) whose light lands at camera (x, y) at one wavelength.

        Newton's method with a finite-difference Jacobian, vectorised over points.

        Parameters
        ----------
        x, y
            Camera column and row.
        wavelength_nm
            The wavelength.
        tol_px, max_iter
            Stop when every point is within ``tol_px`` (camera px), or after ``max_iter``
            steps.

        Returns
        -------
        u, v : ndarray
            SLM column and row.
        """
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        s = self.scale
        cos_r = np.cos(np.deg2rad(self.rotation_deg))
        sin_r = np.sin(np.deg2rad(self.rotation_deg))
        x0, y0 = self.forward(self.slm_centre[0], self.slm_centre[1], wavelength_nm)
        # Start from the inverse of the linear part of the relay.
        dx, dy = (x - x0) / s, (y - y0) / s
        u = self.slm_centre[0] + cos_r * dx + sin_r * dy
        v = self.slm_centre[1] - sin_r * dx + cos_r * dy
        h = 1e-3
        for _ in range(max_iter):
            fx, fy = self.forward(u, v, wavelength_nm)
            fxu, fyu = self.forward(u + h, v, wavelength_nm)
            fxv, fyv = self.forward(u, v + h, wavelength_nm)
            a, b = (fxu - fx) / h, (fxv - fx) / h
            c, d = (fyu - fy) / h, (fyv - fy) / h
            rx, ry = x - fx, y - fy
            det = a * d - b * c
            step_u = (d * rx - b * ry) / det
            step_v = (-c * rx + a * ry) / det
            u, v = u + step_u, v + step_v
            if np.nanmax(np.abs(rx) + np.abs(ry), initial=0.0) < tol_px:
                break
        return u, v
