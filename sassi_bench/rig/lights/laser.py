"""Laser lines (``laser:<nm>``, one per line of the rig's ``lasers_nm``)."""

from __future__ import annotations

import contextlib

from sassi_bench.optics.sources import laser_samples
from sassi_bench.rig.lights.kind import LIGHT_KINDS, LightKind

__all__ = ["Laser", "laser_light"]


def laser_light(wavelength_nm: float) -> str:
    """Light name of a laser line, e.g. ``laser:532``.

    Parameters
    ----------
    wavelength_nm
        The laser's labelled wavelength, nm.

    Returns
    -------
    str
        ``"laser:<nm>"``, the wavelength in its shortest form.

    Examples
    --------
    >>> laser_light(532.0)
    'laser:532'
    """
    return f"laser:{float(wavelength_nm):g}"


@LIGHT_KINDS.register("laser")
class Laser(LightKind):
    """A laser line of finite width (``light.laser_fwhm_nm``) and flux (``light.laser_flux``),
    centred on its label as described.

    Examples
    --------
    >>> Laser().lights((450.0, 532.5), ()), Laser().canonical("laser:532.0")
    (('laser:450', 'laser:532.5'), 'laser:532')
    """

    order = 10
    coherent = True

    def lights(self, lasers_nm, lamps):
        return tuple(laser_light(x) for x in lasers_nm)

    def owns(self, light):
        return light.startswith("laser:")

    def canonical(self, light):
        with contextlib.suppress(ValueError):
            light = laser_light(float(light[6:]))
        return light

    def instruction(self, light):
        return f"Switch on the {light[6:]} nm laser only"

    def settings(self, light, desc):
        return {
            "centre_nm": float(light[6:]),
            "fwhm_nm": desc.light.laser_fwhm_nm,
            "flux": desc.light.laser_flux,
        }

    def samples(self, light, grid_nm, settings):
        return laser_samples(settings["centre_nm"], settings["fwhm_nm"], settings["flux"])
