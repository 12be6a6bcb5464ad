"""Build a :class:`~sassi_bench.rig.Rig` of real devices from a rig description.

Each camera is opened by the class its ``hardware.<camera>.kind`` names
(:data:`~sassi_bench.rig.cameras.CAMERA_KINDS`); vendor SDKs are imported only when a
device opens.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sassi_bench.errors import ConfigError
from sassi_bench.rig.cameras import CAMERA_KINDS, hardware_camera_kinds
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.protocols import Camera
from sassi_bench.rig.rig import Rig

__all__ = ["build_hardware_rig", "open_camera"]


def open_camera(
    name: str, spec: dict[str, Any], state: Callable[[], tuple[int | None, str]]
) -> Camera:
    """Open the camera that ``spec`` (a ``hardware.<camera>`` section) describes, by the
    class of its kind (:data:`~sassi_bench.rig.cameras.CAMERA_KINDS`)."""
    options = {k: v for k, v in spec.items() if k != "kind"}
    kind = spec["kind"]
    if kind not in hardware_camera_kinds():
        raise ConfigError(f"hardware.{name}_camera.kind: unknown camera kind {kind!r}")
    return CAMERA_KINDS[kind].open(name, options, state)


def build_hardware_rig(desc: RigDescription, prompt: Callable[[str], None] | None = None) -> Rig:
    """Open every device of a ``backend: hardware`` rig.

    Parameters
    ----------
    desc
        A validated description with a ``hardware`` section.
    prompt
        Shows the operator an instruction and waits (lights, scenes); defaults to a
        terminal prompt.

    Examples
    --------
    Not run here (it needs the hardware)::

        from sassi_bench.rig import open_rig
        rig = open_rig("procedures/rigs/lab-example.yaml")
    """
    from sassi_bench.rig.hardware.manual import ManualLight, ask_operator
    from sassi_bench.rig.hardware.slm_display import DisplaySlm
    from sassi_bench.rig.hardware.trigger import ArduinoTrigger

    hw = desc.hardware
    if hw is None:
        raise ConfigError("hardware: a hardware rig needs a hardware section")
    ask = prompt or ask_operator
    opened: list[Any] = []
    try:
        options = {k: v for k, v in hw["trigger"].items() if k not in ("kind", "port")}
        trigger = ArduinoTrigger(hw["trigger"]["port"], **options)
        opened.append(trigger)
        light = ManualLight(desc.lasers_nm, desc.wavelength_lamps, prompt=ask)
        slm = DisplaySlm((desc.slm.height, desc.slm.width), monitor=hw["slm"].get("monitor", 1))
        opened.append(slm)

        def state() -> tuple[int | None, str]:
            return slm.pattern_id, light.current

        spectral = open_camera("spectral", hw["spectral_camera"], state)
        opened.append(spectral)
        guide = open_camera("guide", hw["guide_camera"], state)
    except BaseException:
        for device in reversed(opened):  # leave nothing half-open for the next try
            device.close()
        raise
    return Rig(
        description=desc,
        slm=slm,
        spectral_camera=spectral,
        guide_camera=guide,
        light=light,
        trigger=trigger,
        scene_setter=lambda name, pose=None: ask(
            f"Place the {name} target in front of the camera"
            + ("" if pose is None else f", moved to {pose}")
        ),
        scene=None,
    )
