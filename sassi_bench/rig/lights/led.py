"""The white LED (``led``): a colour-science illuminant's spectrum (``light.led``)."""

from __future__ import annotations

from sassi_bench.optics.datasets import require_dataset
from sassi_bench.optics.sources import broadband_samples, colour_illuminant_power
from sassi_bench.rig.lights.kind import LIGHT_KINDS, LightKind

__all__ = ["Led"]


@LIGHT_KINDS.register("led")
class Led(LightKind):
    """A white LED whose spectrum is the colour-science illuminant ``light.led`` names, at
    ``light.broadband_flux`` photons in 400-700 nm.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> Led().settings("led", load_rig_description("sim"))["illuminant"]
    'LED-B3'
    """

    order = 20

    def lights(self, lasers_nm, lamps):
        return ("led",)

    def owns(self, light):
        return light == "led"

    def check(self, desc):
        if desc.light.led is not None:
            require_dataset("illuminant", desc.light.led, "light.led")

    def settings(self, light, desc):
        return {"illuminant": desc.light.led, "flux": desc.light.broadband_flux}

    def samples(self, light, grid_nm, settings):
        power = colour_illuminant_power(settings["illuminant"], grid_nm, "light.led")
        return broadband_samples(power, grid_nm, settings["flux"])
