"""A rig: the device handles a procedure works with."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, field

from sassi_bench.errors import ProcedureError, did_you_mean, step_error
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.lights import kind_of
from sassi_bench.rig.protocols import Camera, LightSource, Slm, Trigger
from sassi_bench.rig.scene_pose import ScenePose

__all__ = ["SCENES", "Rig", "check_light", "check_scene"]

SCENES = ("white", "colorchecker", "natural", "pcb")


def check_scene(name: str, step: str = "set scene") -> None:
    """Refuse a scene name the workbench does not know, suggesting the closest one.

    Examples
    --------
    >>> check_scene("colorchecker")
    >>> check_scene("colorchekcer")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: set scene: ... (did you mean 'colorchecker'?). Fix: ...
    """
    if name not in SCENES:
        raise ProcedureError(
            step_error(
                step,
                f"unknown scene {name!r}{did_you_mean(name, SCENES)}",
                f"use one of {', '.join(SCENES)}",
            )
        )


def check_light(name: str, available: tuple[str, ...], step: str = "light select") -> str:
    """The normalised name of light ``name`` if the rig has it (``"laser:532.0"`` ->
    ``"laser:532"``, ``"lamp:hgar"`` -> ``"lamp:HgAr"``: names match regardless of case);
    otherwise an error naming the rig's lights and the closest one.

    Examples
    --------
    >>> lights = ("off", "laser:532", "led", "lamp:HgAr")
    >>> check_light("Laser:532.0", lights)
    'laser:532'
    >>> check_light("lamp:hgar", lights)
    'lamp:HgAr'
    >>> check_light("lazer:532", lights)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: light select: ... (did you mean 'laser:532'?). Fix: ...
    """
    key = str(name).strip().lower()
    with contextlib.suppress(KeyError):
        key = kind_of(key).canonical(key)
    canonical = {light.lower(): light for light in available}
    if key not in canonical:
        raise ProcedureError(
            step_error(
                step,
                f"{name!r} is not a light of this rig{did_you_mean(key, available)}",
                f"use one of {', '.join(available)}",
            )
        )
    return canonical[key]


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
    closer
        Called once by :meth:`close`.
    simulated_by
        For a hardware rig opened with ``simulate=True``: what runs behind each device's
        adapter, by device key (``{"trigger": "the trigger firmware in simavr"}``).
    """

    description: RigDescription
    slm: Slm
    spectral_camera: Camera
    guide_camera: Camera
    light: LightSource
    trigger: Trigger
    scene_setter: Callable[..., None] = field(repr=False)
    scene: str | None = None
    closer: Callable[[], None] | None = field(default=None, repr=False)
    simulated_by: dict[str, str] = field(default_factory=dict, repr=False)
    _posed: bool = field(default=False, init=False, repr=False)

    def close(self) -> None:
        """Release what the rig holds beyond its devices (a simulated rig's simulators);
        nothing for the virtual bench.

        Examples
        --------
        >>> from sassi_bench import open_rig
        >>> open_rig("sim").close()
        """
        if self.closer is not None:
            closer, self.closer = self.closer, None
            closer()

    def set_scene(self, name: str, pose: ScenePose | None = None) -> None:
        """Put scene ``name`` in front of the camera (``white``, ``colorchecker``, ...).

        ``pose`` moves it (shift in SLM px and rotation about the SLM centre); ``None``
        is the static scene. A moving scene is a pose set per frame. Asking again for the
        static scene already in front does nothing, so an operator is asked to place a
        target once, not before every auto-exposure and plan that uses it.

        Examples
        --------
        >>> from sassi_bench import open_rig
        >>> rig = open_rig("sim")
        >>> rig.set_scene("white")
        >>> rig.scene
        'white'
        """
        check_scene(name)
        if pose is None:
            if name == self.scene and not self._posed:
                return
            self.scene_setter(name)
        else:
            self.scene_setter(name, pose)
        self.scene, self._posed = name, pose is not None
