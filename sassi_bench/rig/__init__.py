"""Devices and rigs: protocols, the virtual bench and the hardware adapters.

Examples
--------
>>> from sassi_bench.rig import open_rig
>>> rig = open_rig("sim")
>>> rig.light.select("laser:532")
>>> rig.spectral_camera.capture().shape
(512, 800)
"""

from __future__ import annotations

import os

from sassi_bench.rig.config import RigDescription, load_rig_description
from sassi_bench.rig.frame import Frame, FrameMeta
from sassi_bench.rig.protocols import Camera, LightSource, Slm, Trigger
from sassi_bench.rig.rig import Rig

__all__ = [
    "Camera",
    "Frame",
    "FrameMeta",
    "LightSource",
    "Rig",
    "RigDescription",
    "Slm",
    "Trigger",
    "load_rig_description",
    "open_rig",
]


def open_rig(rig: str | os.PathLike[str] | RigDescription = "sim") -> Rig:
    """Open a rig by shipped name, YAML path or description.

    Parameters
    ----------
    rig
        ``"sim"`` (default), ``"sim-prototype"``, a path to a rig YAML, or a
        :class:`RigDescription`.

    Returns
    -------
    Rig
        Device handles (``slm``, ``spectral_camera``, ``guide_camera``, ``light``,
        ``trigger``) and ``set_scene``.

    Examples
    --------
    >>> open_rig("sim").description.name
    'sim'
    """
    desc = rig if isinstance(rig, RigDescription) else load_rig_description(rig)
    if desc.backend == "sim":
        from sassi_bench.rig.sim import build_sim_rig

        return build_sim_rig(desc)
    if desc.backend == "hardware":
        from sassi_bench.rig.hardware.build import build_hardware_rig

        return build_hardware_rig(desc)
    raise ValueError(f"backend: unknown backend {desc.backend!r}")  # pragma: no cover
