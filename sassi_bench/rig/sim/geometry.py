"""Where light from an SLM pixel lands on the spectral camera, from first principles.

The virtual bench's SLM -> camera map is a ray trace, not a fitted polynomial:

1. SLM pixel (u, v), relative to the SLM centre and rotated by ``relay.rotation_deg``
   (the SLM's mounting error), becomes a collimated beam whose direction is set by the
   collimating lens (focal length ``f1``, in SLM pixels).
2. The beam crosses the prism (apex angle, incidence, Sellmeier index of the glass),
   traced exactly in 3-D with Snell's law, so field-dependent dispersion, anamorphic
   magnification and the curvature of spectral lines of skew rays all come out of the
   physics.
3. The camera lens (focal length ``f2`` in camera pixels, axis along the deviated
   reference ray) focuses it; ``f2`` is chosen so the 400-700 nm streak at the field
   centre is ``prism.spread_px`` long, and ``f2 / f1 = relay.scale``.
4. The prism sits slightly rolled about the optical axis, so a streak is not quite
   horizontal: its 700 nm end lies ``prism.smile_px`` rows below its 400 nm end at the
   field centre (the roll angle is solved for). With the skew-ray curvature this gives
   the small wavelength-dependent row shift that the calibration fits.
5. Mild radial distortion ``relay.distortion_k1`` (radius normalised to the camera's
   half diagonal).

The bench is built to its description: the focal length, the prism's roll and its
incidence angle are solved with the described glass and apex. A bench built otherwise
(``true_glass``, ``true_apex_deg``: another melt, a prism ground to another angle) then
traces its rays through the true prism, with the camera pointed where the true reference
ray goes (a lab aligns its camera on the light), so its streaks differ in length, shape
and position from what the description predicts.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ConfigError, step_error
from sassi_bench.optics.glass import Glass, get_glass
from sassi_bench.optics.prism import min_deviation_incidence_deg, trace_prism
from sassi_bench.rig.config import PrismConfig, RelayConfig

__all__ = ["SpectralRelay", "linear_upsampler"]

_BAND_NM = (400.0, 700.0)


def _rot_y(angle_rad: float) -> NDArray[np.float64]:
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


@dataclass
class SpectralRelay:
    """The SLM -> prism -> spectral camera optics of the virtual bench.

    Parameters
    ----------
    slm_shape, camera_shape
        (height, width) of the SLM and of the spectral camera.
    relay, prism
        The rig description's sections.
    true_glass, true_apex_deg
        The prism as built, when it differs from the description (default: as described).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> d = load_rig_description("sim")
    >>> relay = SpectralRelay((400, 640), (512, 800), d.relay, d.prism)
    >>> x, y = relay.forward([319.5, 319.5], [199.5, 199.5], [400.0, 700.0])
    >>> round(float(x[1] - x[0]), 6)
    68.0
    """

    slm_shape: tuple[int, int]
    camera_shape: tuple[int, int]
    relay: RelayConfig
    prism: PrismConfig
    true_glass: Glass | None = None
    true_apex_deg: float | None = None

    def __post_init__(self) -> None:
        self.glass: Glass = get_glass(self.prism.glass)
        self.apex_deg = float(self.prism.apex_deg)
        h, w = self.slm_shape
        hc, wc = self.camera_shape
        self.slm_centre = ((w - 1) / 2.0, (h - 1) / 2.0)
        self.optical_centre = (
            (wc - 1) / 2.0 + self.relay.offset_px[0],
            (hc - 1) / 2.0 + self.relay.offset_px[1],
        )
        self.distortion_radius = 0.5 * float(np.hypot(wc, hc))
        n_ref = float(self.glass.index(self.prism.reference_nm))
        self.incidence_deg = (
            self.prism.incidence_deg
            if self.prism.incidence_deg is not None
            else min_deviation_incidence_deg(n_ref, self.prism.apex_deg)
        )
        n_lo, n_hi = self.glass.index(np.array(_BAND_NM))
        self._n_band = (float(n_lo), float(n_hi))
        # Solve the camera focal length (streak length = spread_px) and the prism roll
        # (end-to-end row offset = smile_px) at the field centre by fixed-point iteration.
        self.f2, self.roll_rad = 1000.0, 0.0
        for _ in range(8):
            self._to_camera = self._align_camera(n_ref)
            x, y = self.forward(
                [self.slm_centre[0]] * 2, [self.slm_centre[1]] * 2, np.array(_BAND_NM)
            )
            self.f2 *= self.prism.spread_px / float(x[1] - x[0])
            self.roll_rad += np.arctan2(
                self.prism.smile_px - float(y[1] - y[0]), float(x[1] - x[0])
            )
        if self.true_glass is not None or self.true_apex_deg is not None:
            self.glass = self.true_glass if self.true_glass is not None else self.glass
            self.apex_deg = float(
                self.true_apex_deg if self.true_apex_deg is not None else self.apex_deg
            )
            self._to_camera = self._align_camera(float(self.glass.index(self.prism.reference_nm)))

    def _trace(self, d: NDArray[np.float64], n: ArrayLike) -> NDArray[np.float64]:
        """Trace directions through the rolled prism (roll about the optical axis)."""
        c, s = np.cos(self.roll_rad), np.sin(self.roll_rad)
        roll = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        out = trace_prism(d @ roll, n, self.apex_deg, self.incidence_deg)
        return out @ roll.T

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
        yaw = _rot_y(-np.arctan2(axis[0], axis[2]))
        flat = yaw @ axis
        e = np.arctan2(flat[1], flat[2])
        pitch = np.array(
            [[1.0, 0.0, 0.0], [0.0, np.cos(e), -np.sin(e)], [0.0, np.sin(e), np.cos(e)]]
        )
        return pitch @ yaw

    @property
    def f1(self) -> float:
        """Collimator focal length in SLM pixels."""
        return self.f2 / self.relay.scale

    def forward(
        self, u: ArrayLike, v: ArrayLike, wavelength_nm: ArrayLike
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Camera position of SLM pixel (u, v) at a wavelength (broadcasting).

        Returns
        -------
        x, y : ndarray
            Camera column and row (pixel centres at integers).
        """
        # Field terms depend on (u, v) only and the index on the wavelength only: compute
        # each on its own (unbroadcast) shape and let the ray trace broadcast them.
        u, v = np.broadcast_arrays(np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64))
        n = self.glass.index(np.asarray(wavelength_nm, dtype=np.float64))
        rot = np.deg2rad(self.relay.rotation_deg)
        du = u - self.slm_centre[0]
        dv = v - self.slm_centre[1]
        hu = np.cos(rot) * du - np.sin(rot) * dv
        hv = np.sin(rot) * du + np.cos(rot) * dv
        d = np.stack([hu, hv, np.full_like(hu, self.f2 / self.relay.scale)], axis=-1)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        out = self._trace(d, n) @ self._to_camera.T
        xu = self.f2 * out[..., 0] / out[..., 2]
        yu = self.f2 * out[..., 1] / out[..., 2]
        factor = 1.0 + self.relay.distortion_k1 * (xu**2 + yu**2) / self.distortion_radius**2
        x = self.optical_centre[0] + xu * factor
        y = self.optical_centre[1] + yu * factor
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
        """
        x = np.asarray(x, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        s = self.relay.scale
        cos_r = np.cos(np.deg2rad(self.relay.rotation_deg))
        sin_r = np.sin(np.deg2rad(self.relay.rotation_deg))
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


def linear_upsampler(coarse_positions: NDArray[np.float64], size: int) -> NDArray[np.float32]:
    """Matrix that linearly interpolates samples at ``coarse_positions`` onto 0..size-1.

    ``fine = W @ coarse`` (rows: fine pixels). The coarse positions must bracket the
    fine range, so no sample is extrapolated.

    Examples
    --------
    >>> w = linear_upsampler(np.array([-4.0, 4.0, 12.0]), 9)
    >>> (w @ np.array([-4.0, 4.0, 12.0])).tolist()
    [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]
    """
    fine = np.arange(size, dtype=np.float64)
    idx = np.clip(
        np.searchsorted(coarse_positions, fine, side="right") - 1, 0, len(coarse_positions) - 2
    )
    left = coarse_positions[idx]
    frac = (fine - left) / (coarse_positions[idx + 1] - left)
    w = np.zeros((size, len(coarse_positions)), dtype=np.float32)
    rows = np.arange(size)
    w[rows, idx] = 1.0 - frac
    w[rows, idx + 1] = frac
    return w
