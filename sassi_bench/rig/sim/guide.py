"""The RGB guide camera of the virtual bench: spectral sensitivities and homography."""

from __future__ import annotations

import cv2
import numpy as np
from numpy.typing import NDArray

from sassi_bench.optics.datasets import camera_sensitivities
from sassi_bench.rig.config import GuideCameraConfig

__all__ = ["GuideOptics", "guide_homography"]

# Fraction of the scene light the beamsplitter sends to the guide camera.
GUIDE_SPLIT = 0.1


def guide_homography(cfg: GuideCameraConfig, slm_shape: tuple[int, int]) -> NDArray[np.float64]:
    """The 3x3 guide -> SLM homography of a rig description.

    Without an explicit ``homography`` the guide camera is a similarity: the SLM
    position ``slm_centre + offset_px`` is seen at the guide's centre, magnified by
    ``scale`` guide px per SLM px and rotated by ``rotation_deg``.

    Examples
    --------
    >>> cfg = GuideCameraConfig(width=100, height=80, scale=2.0)
    >>> h = guide_homography(cfg, (40, 50))
    >>> (h @ [49.5, 39.5, 1.0]).round(6).tolist()  # guide centre -> SLM centre
    [24.5, 19.5, 1.0]
    """
    if cfg.homography is not None:
        h = np.asarray(cfg.homography, dtype=np.float64)
        return h / h[2, 2]
    t = np.deg2rad(cfg.rotation_deg)
    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]]) / cfg.scale
    guide_centre = np.array([(cfg.width - 1) / 2.0, (cfg.height - 1) / 2.0])
    slm_centre = np.array([(slm_shape[1] - 1) / 2.0, (slm_shape[0] - 1) / 2.0])
    h = np.eye(3)
    h[:2, :2] = rot
    h[:2, 2] = slm_centre + np.asarray(cfg.offset_px) - rot @ guide_centre
    return h


class GuideOptics:
    """Renders what the guide camera sees of a scene (electron rates per channel).

    Parameters
    ----------
    cfg
        The rig's guide camera section.
    slm_shape
        SLM (height, width); the homography maps guide pixels to SLM pixels.
    grid
        The scene wavelength grid.
    sensitivities
        The sensor's true RGB curves (3, len(grid)); default: those ``cfg`` names.
    """

    def __init__(
        self,
        cfg: GuideCameraConfig,
        slm_shape: tuple[int, int],
        grid: NDArray[np.float64],
        sensitivities: NDArray[np.float64] | None = None,
    ) -> None:
        self.cfg = cfg
        self.shape = (cfg.height, cfg.width, 3)
        self.guide_to_slm = guide_homography(cfg, slm_shape)
        self.sensitivities = (
            camera_sensitivities(cfg.sensitivities, grid)
            if sensitivities is None
            else np.asarray(sensitivities, dtype=np.float64)
        )
        self.grid = grid
        # Guide pixels per SLM pixel, from the homography's local area at the centre.
        self.scale = 1.0 / np.sqrt(abs(np.linalg.det(self.guide_to_slm[:2, :2])))

    def grid_weights(self, wavelengths_nm, weights) -> NDArray[np.float64]:
        """Spread weighted samples onto the grid with linear (hat) weights.

        Scenes interpolate reflectance linearly between grid wavelengths, so this is
        exact for laser lines between grid points too.
        """
        grid = self.grid
        pos = np.clip(np.searchsorted(grid, wavelengths_nm) - 1, 0, grid.size - 2)
        frac = np.clip((wavelengths_nm - grid[pos]) / (grid[pos + 1] - grid[pos]), 0.0, 1.0)
        out = np.zeros(grid.size)
        np.add.at(out, pos, weights * (1.0 - frac))
        np.add.at(out, pos + 1, weights * frac)
        return out

    def electron_rate(self, scene, wavelengths_nm, weights) -> NDArray[np.float32]:
        """Electron rate (H, W, 3) of the guide camera for a scene under a light."""
        on_grid = self.grid_weights(wavelengths_nm, weights)
        channels = scene.project(self.sensitivities * on_grid[None, :])  # (3, Hc, Wc)
        slm_px_per_guide_px = 1.0 / self.scale**2
        channels *= np.float32(GUIDE_SPLIT * slm_px_per_guide_px)
        # Anti-alias to the guide's sampling and add its optics blur, in canvas pixels.
        aa = 0.5 * np.sqrt(max(1.0 / self.scale**2 - 1.0, 0.0))
        sigma = float(np.hypot(self.cfg.blur_px / self.scale, aa))
        shift = np.array([[1.0, 0.0, scene.margin], [0.0, 1.0, scene.margin], [0.0, 0.0, 1.0]])
        to_canvas = shift @ self.guide_to_slm
        out = np.empty(self.shape, dtype=np.float32)
        for c in range(3):
            plane = channels[c]
            if sigma > 0.05:
                plane = cv2.GaussianBlur(plane, (0, 0), sigmaX=sigma, sigmaY=sigma)
            out[..., c] = cv2.warpPerspective(
                plane,
                to_canvas,
                (self.cfg.width, self.cfg.height),
                flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
                borderMode=cv2.BORDER_CONSTANT,
                borderValue=0.0,
            )
        return out
