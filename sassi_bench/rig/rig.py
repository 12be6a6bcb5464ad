"""A rig: the device handles a procedure works with."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.protocols import Camera, LightSource, Slm, Trigger
from sassi_bench.rig.scene_pose import ScenePose

__all__ = ["SCENES", "Rig"]

SCENES = ("white", "colorchecker", "natural", "pcb")


@dataclass
class Rig:
    """Device handles of one bench, simulated or real.

    Procedures receive a ``Rig`` and use only its devices and :meth:`set_scene`; on
    a real bench ``set_scene`` asks the operator to place the target.

    Parameters
    ----------
    description
        The validated rig description.
    slm, spectral_camera, guide_camera, light, trigger
        Device handles implementing the protocols of :mod:`sassi_bench.rig.protocols`.
    scene_setter
        Called by :meth:`set_scene` with the scene name, and with the pose as a second
        argument when one is given (a moving scene).
    """

    description: RigDescription
    slm: Slm
    spectral_camera: Camera
    guide_camera: Camera
    light: LightSource
    trigger: Trigger
    scene_setter: Callable[..., None] = field(repr=False)
    scene: str | None = None

    def set_scene(self, name: str, pose: ScenePose | None = None) -> None:
        """Put scene ``name`` in front of the camera (``white``, ``colorchecker``, ...).

        ``pose`` moves it (shift in SLM px and rotation about the SLM centre); ``None``
        is the static scene. A moving scene is a pose set per frame.
        """
        if name not in SCENES:
            raise ProcedureError(
                step_error(
                    "set scene", f"unknown scene {name!r}", f"use one of {', '.join(SCENES)}"
                )
            )
        if pose is None:
            self.scene_setter(name)
        else:
            self.scene_setter(name, pose)
        self.scene = name
