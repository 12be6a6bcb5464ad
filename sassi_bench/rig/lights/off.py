"""No light: the dark frames' (``off``)."""

from __future__ import annotations

import numpy as np

from sassi_bench.optics.sources import SpectralSamples
from sassi_bench.rig.lights.kind import LIGHT_KINDS, LightKind

__all__ = ["OffLight"]


@LIGHT_KINDS.register("off")
class OffLight(LightKind):
    """Every light off (every rig has it).

    Examples
    --------
    >>> OffLight().lights((532.0,), ()), OffLight().instruction("off")
    (('off',), 'Switch every light off')
    """

    order = 0

    def lights(self, lasers_nm, lamps):
        return ("off",)

    def owns(self, light):
        return light == "off"

    def instruction(self, light):
        return "Switch every light off"

    def samples(self, light, grid_nm, settings):
        return SpectralSamples(np.array([550.0]), np.array([0.0]))
