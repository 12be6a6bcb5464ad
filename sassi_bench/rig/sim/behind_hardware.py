"""The virtual bench behind a real rig's simulated devices (``--simulate``).

A ``backend: hardware`` rig rehearsed without its hardware drives its real adapters
against simulators of the devices (:mod:`sassi_bench.rig.hardware.simulators`); this
is what those simulators look at: the rig's own optics as a virtual bench, given the
pattern the SLM window displays (read back from the virtual display) and asked for the
cameras' pixels. The bench is built from the rig's description as a ``backend: sim``
rig of the same optics (the bench's own parts, such as the LED's spectrum, default as
on any virtual bench) with the rig's ``as_built`` and ``nuisance`` sections.

Examples
--------
>>> from sassi_bench.rig.config import load_rig_description
>>> behind = BenchBehindHardware(load_rig_description("lab-example"))
>>> behind.spectral_shape, behind.guide_shape
((2048, 2048), (1080, 1440, 3))
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sassi_bench.rig.config import RigDescription, rig_description_from_dict
from sassi_bench.rig.scene_pose import ScenePose
from sassi_bench.rig.sim.bench import VirtualBench

__all__ = ["BenchBehindHardware", "bench_description"]


def bench_description(desc: RigDescription) -> RigDescription:
    """The ``backend: sim`` description of a hardware rig's optics, with its bench-only
    sections.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> bench_description(load_rig_description("lab-example")).backend
    'sim'
    """
    data = desc.to_dict()
    data["backend"] = "sim"
    data.pop("hardware", None)
    data.update(desc.bench_sections)
    return rig_description_from_dict(data, desc.source or "<dict>")


class BenchBehindHardware:
    """A virtual bench answering a simulated rig's devices.

    Parameters
    ----------
    desc
        A ``backend: hardware`` rig description.
    """

    def __init__(self, desc: RigDescription) -> None:
        self.bench = VirtualBench(bench_description(desc))
        self.spectral_shape = self.bench.camera_shape
        self.guide_shape = (*self.bench.guide.shape[:2], 3)
        self.spectral_bits = self.bench.sensor.bit_depth
        self.guide_bits = self.bench.guide_sensor.bit_depth

    def show(self, pattern: NDArray[np.uint8]) -> None:
        """The SLM displays ``pattern`` (as read back from its window)."""
        self.bench.pattern = pattern

    def set_light(self, name: str) -> None:
        """The operator switched to light ``name``."""
        self.bench.set_light(name)

    def set_scene(self, name: str, pose: ScenePose | None = None) -> None:
        """The operator placed scene ``name`` (at ``pose``)."""
        self.bench.set_scene(name, pose)

    def spectral(self, exposure_s: float) -> NDArray[np.uint16]:
        """One spectral frame of ``exposure_s`` seconds, as its sensor reads it."""
        bench = self.bench
        rate = bench.spectral_rate()
        rng = bench.noise_rng("spectral", exposure_s)
        rate = bench.nuisance.spectral_rate(rate, bench.light, rng)
        data = bench.sensor.expose(rate, exposure_s, rng)
        bench.advance_clock(exposure_s)
        return data

    def guide(self, exposure_s: float) -> NDArray[np.uint16]:
        """One guide frame of ``exposure_s`` seconds (height, width, 3)."""
        bench = self.bench
        rng = bench.noise_rng("guide", exposure_s)
        return bench.guide_sensor.expose(bench.guide_rate(), exposure_s, rng)
