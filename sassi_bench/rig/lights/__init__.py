"""Light kinds (laser, lamp, LED, halogen, fluorescent, off): one class each, registered
under its name in :data:`LIGHT_KINDS`."""

from sassi_bench.rig.lights.kind import LIGHT_KINDS, LightKind, kind_of, light_kinds, light_names
from sassi_bench.rig.lights.laser import laser_light

__all__ = ["LIGHT_KINDS", "LightKind", "kind_of", "laser_light", "light_kinds", "light_names"]
