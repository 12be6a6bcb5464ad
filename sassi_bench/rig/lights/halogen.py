"""The halogen lamp (``halogen``): a blackbody of the lamp's colour temperature."""

from __future__ import annotations

from sassi_bench.optics.sources import blackbody_power, broadband_samples
from sassi_bench.rig.lights.kind import LIGHT_KINDS, LightKind

__all__ = ["Halogen"]


@LIGHT_KINDS.register("halogen")
class Halogen(LightKind):
    """A halogen lamp: a blackbody at ``light.halogen_k``, at ``light.broadband_flux``
    photons in 400-700 nm.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> Halogen().settings("halogen", load_rig_description("sim"))["temperature_k"]
    3000
    """

    order = 30

    def lights(self, lasers_nm, lamps):
        return ("halogen",)

    def owns(self, light):
        return light == "halogen"

    def settings(self, light, desc):
        return {"temperature_k": desc.light.halogen_k, "flux": desc.light.broadband_flux}

    def samples(self, light, grid_nm, settings):
        power = blackbody_power(grid_nm, settings["temperature_k"])
        return broadband_samples(power, grid_nm, settings["flux"])
