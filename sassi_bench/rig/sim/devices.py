"""Simulated devices: thin facades over a :class:`~sassi_bench.rig.sim.bench.VirtualBench`."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from sassi_bench.rig.base import CameraBase, Exposure, LightSourceBase, SlmBase, TriggerBase
from sassi_bench.rig.cameras import CAMERA_KINDS
from sassi_bench.rig.sim.bench import VirtualBench

__all__ = ["SimGuideCamera", "SimLight", "SimSlm", "SimSpectralCamera", "SimTrigger"]


class SimTrigger(TriggerBase):
    """Counts SLM pulses (one per pattern shown) and the ones passed to the cameras."""

    def __init__(self) -> None:
        super().__init__()
        self._received = 0
        self._passed = 0

    def pulse(self) -> None:
        """An SLM master pulse arrives."""
        self._received += 1
        if self.armed and self._received % self.divider == 0:
            self._passed += 1

    def _arm(self, armed: bool) -> None:
        pass

    def _set_divider(self, n: int) -> None:
        pass

    def counters(self) -> dict[str, int]:
        return {"received": self._received, "passed": self._passed}


class SimSlm(SlmBase):
    """The virtual bench's SLM."""

    def __init__(self, bench: VirtualBench, trigger: SimTrigger) -> None:
        super().__init__(bench.slm_shape)
        self._bench = bench
        self._trigger = trigger

    def _display(self, pattern: NDArray[np.uint8]) -> None:
        self._bench.pattern = pattern
        self._trigger.pulse()


class SimLight(LightSourceBase):
    """Lasers, LED, halogen and fluorescent lamps of the virtual bench."""

    def __init__(self, bench: VirtualBench) -> None:
        super().__init__(bench.lights)
        self._bench = bench

    def _switch(self, name: str) -> None:
        self._bench.set_light(name)


@CAMERA_KINDS.register("bench")
class BenchCamera(CameraBase):
    """A camera of the virtual bench: :meth:`open` gives the spectral or the guide one."""

    #: The bench's cameras come with a ``backend: sim`` rig, not a ``hardware`` section.
    hardware = False

    @classmethod
    def open(cls, name: str, options: dict, context: tuple) -> BenchCamera:
        """The bench's camera ``name`` (``"spectral"`` or ``"guide"``); ``context`` is the
        bench, its SLM and its light."""
        bench, slm, light = context
        role = {"spectral": SimSpectralCamera, "guide": SimGuideCamera}[name]
        return role(bench, slm, light)


class SimSpectralCamera(BenchCamera):
    """The monochrome spectral camera behind the prism."""

    def __init__(self, bench: VirtualBench, slm: SimSlm, light: SimLight) -> None:
        cam = bench.description.spectral_camera
        super().__init__(
            "spectral", bench.camera_shape, cam.bit_depth, cam.exposure_range_s, exposure_s=0.05
        )
        self._bench, self._slm, self._light = bench, slm, light

    def _expose(self) -> Exposure:
        rate = self._bench.spectral_rate()
        rng = self._bench.noise_rng("spectral", self.exposure_s)
        rate = self._bench.nuisance.spectral_rate(rate, self._bench.light, rng)
        data = self._bench.sensor.expose(rate, self.exposure_s, rng)
        self._bench.advance_clock(self.exposure_s)
        return Exposure(
            data, self._slm.pattern_id, self._light.current, {"scene": self._bench.scene.name}
        )


class SimGuideCamera(BenchCamera):
    """The RGB guide camera (sees the scene before the SLM)."""

    def __init__(self, bench: VirtualBench, slm: SimSlm, light: SimLight) -> None:
        gc = bench.description.guide_camera
        super().__init__(
            "guide", bench.guide.shape, gc.bit_depth, gc.exposure_range_s, exposure_s=0.02
        )
        self._bench, self._slm, self._light = bench, slm, light

    def _expose(self) -> Exposure:
        rate = self._bench.guide_rate()
        rng = self._bench.noise_rng("guide", self.exposure_s)
        data = self._bench.guide_sensor.expose(rate, self.exposure_s, rng)
        return Exposure(
            data, self._slm.pattern_id, self._light.current, {"scene": self._bench.scene.name}
        )
