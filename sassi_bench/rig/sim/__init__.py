"""The virtual SASSI bench: simulated devices over a physically faithful renderer.

Examples
--------
>>> from sassi_bench import open_rig
>>> from sassi_bench.rig.sim import truth
>>> rig = open_rig("sim")
>>> truth(rig).guide_to_slm.shape
(3, 3)
"""

from __future__ import annotations

from sassi_bench.rig.cameras import CAMERA_KINDS
from sassi_bench.rig.config import RigDescription
from sassi_bench.rig.rig import Rig
from sassi_bench.rig.sim.bench import VirtualBench
from sassi_bench.rig.sim.devices import (
    SimLight,
    SimSlm,
    SimTrigger,
)
from sassi_bench.rig.sim.ground_truth import BenchTruth, register_bench, truth

__all__ = ["BenchTruth", "VirtualBench", "build_sim_rig", "truth"]


def build_sim_rig(desc: RigDescription, sparse_limit: int | None = None) -> Rig:
    """Build a simulated :class:`~sassi_bench.rig.Rig` from a description."""
    bench = VirtualBench(desc, sparse_limit=sparse_limit)
    trigger = SimTrigger()
    slm = SimSlm(bench, trigger)
    light = SimLight(bench)
    rig = Rig(
        description=desc,
        slm=slm,
        spectral_camera=CAMERA_KINDS["bench"].open("spectral", {}, (bench, slm, light)),
        guide_camera=CAMERA_KINDS["bench"].open("guide", {}, (bench, slm, light)),
        light=light,
        trigger=trigger,
        scene_setter=bench.set_scene,
        scene="white",
    )
    register_bench(rig, bench)
    return rig
