"""Wavelength lamps (``lamp:<name>``): gas-discharge pen-ray lamps whose atomic lines
anchor the wavelength axis, their lines from a shipped table (HgAr, Ne) or a lab's CSV."""

from __future__ import annotations

from sassi_bench.optics.lamps import lamp_name, lamp_samples
from sassi_bench.rig.lights.kind import LIGHT_KINDS, LightKind

__all__ = ["Lamp"]


@LIGHT_KINDS.register("lamp")
class Lamp(LightKind):
    """A pen-ray lamp per ``wavelength_lamps`` entry (a shipped table's name, or the path of
    a lab's CSV of lines), rendered at the lasers' flux (its lines through the diffuser).

    Examples
    --------
    >>> Lamp().lights((), ("hgar", "lab/Kr.csv"))
    ('lamp:HgAr', 'lamp:Kr')
    >>> Lamp().instruction("lamp:HgAr")
    'Switch on the HgAr lamp only (let it warm up for 2 minutes)'
    """

    order = 50

    def lights(self, lasers_nm, lamps):
        return tuple(f"lamp:{lamp_name(entry)}" for entry in lamps)

    def owns(self, light):
        return light.startswith("lamp:")

    def instruction(self, light):
        # A pen-ray lamp's spectrum settles over its first minutes (argon first).
        return f"Switch on the {light[5:]} lamp only (let it warm up for 2 minutes)"

    def settings(self, light, desc):
        return {"lines": desc.lamp_lines()[light[5:]], "flux": desc.light.laser_flux}

    def samples(self, light, grid_nm, settings):
        return lamp_samples(settings["lines"], settings["flux"])
