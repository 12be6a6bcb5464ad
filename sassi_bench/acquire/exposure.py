"""Automatic exposure: find the exposure that fills a camera to a target level."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.trigger_gate import armed
from sassi_bench.errors import DeviceError, step_error
from sassi_bench.rig.rig import Rig

__all__ = ["auto_exposure"]


def auto_exposure(
    rig: Rig,
    light: str,
    pattern: Mapping[str, Any],
    *,
    camera: str = "spectral",
    target_fraction: float = 0.6,
    start_s: float = 0.01,
    max_s: float = 2.0,
    percentile: float = 99.95,
    iterations: int = 6,
) -> float:
    """Exposure (s) at which the bright end of a frame sits at ``target_fraction``.

    Captures a few frames of ``pattern`` under ``light``, scaling the exposure by the
    ratio of the target level to the measured ``percentile`` level above the camera's
    dark level (measured once with the light off). Saturated frames halve the exposure.

    Parameters
    ----------
    rig
        Device handles.
    light, pattern
        What to expose for: a light name and a pattern descriptor.
    camera
        ``"spectral"`` or ``"guide"``.
    target_fraction
        Target level as a fraction of the ADC range.
    start_s, max_s
        First guess and upper limit (seconds); the camera's own range also applies.

    Returns
    -------
    float
        The exposure, already set on the camera.

    Raises
    ------
    DeviceError
        If even the longest allowed exposure stays far below the target (no light).

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> rig = open_rig("sim")
    >>> t = auto_exposure(rig, "laser:532", {"kind": "full"})
    >>> 0 < t < 2
    True
    """
    with armed(rig):  # a camera on a line trigger exposes for the pulses it passes
        return _auto_exposure(
            rig, light, pattern, camera, target_fraction, percentile, start_s, max_s, iterations
        )


def _auto_exposure(
    rig: Rig,
    light: str,
    pattern: Mapping[str, Any],
    camera: str,
    target_fraction: float,
    percentile: float,
    start_s: float,
    max_s: float,
    iterations: int,
) -> float:
    cam = rig.spectral_camera if camera == "spectral" else rig.guide_camera
    lo, hi = cam.exposure_range_s
    hi = min(hi, max_s)
    full_scale = 2**cam.bit_depth - 1
    rig.slm.show(render_pattern(pattern, rig.slm.shape))
    rig.light.select("off")
    cam.set_exposure(float(np.clip(start_s, lo, hi)))
    dark = float(np.median(cam.capture().data))
    rig.light.select(light)
    exposure = float(np.clip(start_s, lo, hi))
    for _ in range(iterations):
        cam.set_exposure(exposure)
        data = cam.capture().data
        level = float(np.percentile(data, percentile)) - dark
        if data.max() >= full_scale:
            proposal = exposure / 2
        elif level <= 0:
            proposal = exposure * 10
        else:
            proposal = exposure * (target_fraction * full_scale - dark) / level
        proposal = float(np.clip(proposal, lo, hi))
        if abs(proposal - exposure) <= 0.03 * exposure:
            exposure = proposal
            break
        exposure = proposal
    cam.set_exposure(exposure)
    if exposure >= hi and level < 0.1 * target_fraction * full_scale:
        raise DeviceError(
            step_error(
                f"auto exposure ({light})",
                f"the brightest pixels reach only {level:.0f} of {full_scale} ADU at the longest "
                f"exposure {hi:g} s",
                "check that the light is on and reaches the camera, or raise exposure.max_s",
            )
        )
    return exposure
