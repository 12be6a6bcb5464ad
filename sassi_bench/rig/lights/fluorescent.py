"""The fluorescent lamp (``fluorescent``): a colour-science illuminant (``light.fluorescent``)."""

from __future__ import annotations

from sassi_bench.optics.datasets import require_dataset
from sassi_bench.optics.sources import broadband_samples, colour_illuminant_power
from sassi_bench.rig.lights.kind import LIGHT_KINDS, LightKind

__all__ = ["Fluorescent"]


@LIGHT_KINDS.register("fluorescent")
class Fluorescent(LightKind):
    """A fluorescent lamp whose spectrum is the colour-science illuminant
    ``light.fluorescent`` names, at ``light.broadband_flux`` photons in 400-700 nm.

    Examples
    --------
    >>> Fluorescent().owns("fluorescent"), Fluorescent().owns("led")
    (True, False)
    """

    order = 40

    def lights(self, lasers_nm, lamps):
        return ("fluorescent",)

    def owns(self, light):
        return light == "fluorescent"

    def check(self, desc):
        if desc.light.fluorescent is not None:
            require_dataset("illuminant", desc.light.fluorescent, "light.fluorescent")

    def settings(self, light, desc):
        return {"illuminant": desc.light.fluorescent, "flux": desc.light.broadband_flux}

    def samples(self, light, grid_nm, settings):
        power = colour_illuminant_power(settings["illuminant"], grid_nm, "light.fluorescent")
        return broadband_samples(power, grid_nm, settings["flux"])
