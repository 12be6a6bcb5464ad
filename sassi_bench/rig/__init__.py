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
from sassi_bench.rig.device_check import RigCheckReport
from sassi_bench.rig.frame import Frame, FrameMeta
from sassi_bench.rig.protocols import Camera, LightSource, Slm, Trigger
from sassi_bench.rig.rig import Rig

__all__ = [
    "Camera",
    "Frame",
    "FrameMeta",
    "LightSource",
    "Rig",
    "RigCheckReport",
    "RigDescription",
    "Slm",
    "Trigger",
    "check_rig",
    "load_rig_description",
    "open_rig",
]


def open_rig(
    rig: str | os.PathLike[str] | RigDescription = "sim", *, simulate: bool = False
) -> Rig:
    """Open a rig by shipped name, YAML path or description.

    Parameters
    ----------
    rig
        ``"sim"`` (default), ``"sim-prototype"``, a path to a rig YAML, or a
        :class:`RigDescription`.
    simulate
        For a ``backend: hardware`` rig: open its real adapters against simulators of
        its devices with the virtual bench behind them
        (:mod:`sassi_bench.rig.hardware.simulators`; :meth:`Rig.close`, or the end of the
        process, stops them). A ``backend: sim`` rig is simulated already.

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
    if desc.backend == "hardware" and simulate:
        return _simulated_rig(desc)
    if desc.backend == "hardware":
        from sassi_bench.rig.hardware.build import build_hardware_rig

        return build_hardware_rig(desc)
    raise ValueError(f"backend: unknown backend {desc.backend!r}")  # pragma: no cover


def _simulated_rig(desc: RigDescription) -> Rig:
    """A hardware rig's adapters on simulators, the virtual bench behind them."""
    import atexit

    from sassi_bench.rig.hardware.simulators import build_simulated_rig
    from sassi_bench.rig.sim import register_bench
    from sassi_bench.rig.sim.behind_hardware import BenchBehindHardware

    behind = BenchBehindHardware(desc)
    simulated = build_simulated_rig(desc, behind)
    rig = simulated.rig
    assert rig is not None
    rig.closer = simulated.close
    atexit.register(rig.close)
    register_bench(rig, behind.bench)
    return rig


def check_rig(
    rig: str | os.PathLike[str] | RigDescription = "sim", *, simulate: bool = False
) -> RigCheckReport:
    """Open every device of a rig in turn and check it against the description.

    A real bench's devices are opened one at a time, so every missing one is reported
    with its fix; the virtual bench reports its virtual devices. Nothing stops at the
    first failure (see :mod:`sassi_bench.rig.device_check`).

    Examples
    --------
    >>> report = check_rig("sim")
    >>> report.ok, report.failed_devices()
    (True, [])
    """
    from sassi_bench.rig.device_check import check_devices, devices_of, virtual_findings

    desc = rig if isinstance(rig, RigDescription) else load_rig_description(rig)
    if desc.backend == "hardware" and not simulate:
        from sassi_bench.rig.hardware.check import check_hardware_rig

        return check_hardware_rig(desc)
    opened = open_rig(desc, simulate=simulate)
    try:
        return check_devices(desc, devices_of(opened), virtual_findings(opened))
    finally:
        opened.close()
