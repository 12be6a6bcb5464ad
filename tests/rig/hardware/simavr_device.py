"""The trigger firmware in simavr for the tests: the package's simulator
(:mod:`sassi_bench.rig.hardware.simulators.simavr_trigger`), with pulses counted out."""

from __future__ import annotations

import tempfile
from pathlib import Path

from sassi_bench.rig.hardware.simulators.simavr_trigger import (
    SimavrTrigger,
    build_firmware,
    build_harness,
)
from sassi_bench.rig.hardware.simulators.simavr_trigger import (
    simavr_missing as toolchain_missing,
)

__all__ = ["SimavrDevice", "build_firmware", "build_harness", "toolchain_missing"]


class SimavrDevice(SimavrTrigger):
    """One simulated Arduino: ``port`` for the driver, ``pulse(n)`` on the SLM input pin."""

    def __init__(self, harness: Path, firmware: Path) -> None:
        self._workdir = Path(tempfile.mkdtemp(prefix="simavr-"))
        super().__init__(self._workdir, firmware, harness)

    def close(self) -> None:
        super().close()
        self._workdir.rmdir()

    def pulse(self, n: int = 1) -> bool:
        """Send ``n`` SLM master pulses; True when the last was passed to the cameras."""
        passed = False
        for _ in range(n):
            passed = super().pulse()
        return passed
