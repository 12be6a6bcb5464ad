"""The trigger behind ``--simulate``: the firmware itself in simavr where its toolchain is
installed, else the serial fake of its protocol, saying which one runs and why."""

from __future__ import annotations

import pytest

from sassi_bench.rig.hardware.simulators import simavr_trigger
from sassi_bench.rig.hardware.simulators.serial_trigger import TriggerSimulator
from sassi_bench.rig.hardware.simulators.simavr_trigger import SimavrTrigger, trigger_simulator
from sassi_bench.rig.hardware.trigger import ArduinoTrigger

MISSING = simavr_trigger.simavr_missing()


@pytest.mark.skipif(MISSING is not None, reason=f"{MISSING} (.ci/run installs them)")
def test_with_the_toolchain_the_firmware_runs_in_simavr(tmp_path):
    simulator, runs = trigger_simulator(tmp_path)
    try:
        assert isinstance(simulator, SimavrTrigger) and runs == "the trigger firmware in simavr"
        with ArduinoTrigger(str(simulator.link), boot_s=5.0) as driver:
            assert driver.identity.startswith("SASSI-TRIGGER 1 ATMEGA328P")
            assert simulator.pulse() is False  # disarmed: counted, not passed
            driver.set_divider(2)
            driver.arm()
            assert [simulator.pulse() for _ in range(4)] == [False, True, False, True]
            assert driver.counters() == {"received": 5, "passed": 2}
            assert simulator.camera_pulses == 2
    finally:
        simulator.close()
    assert not simulator.link.exists()


def test_without_the_toolchain_the_serial_fake_runs_and_says_why(tmp_path, monkeypatch):
    reason = "avr-gcc not found; apt-get install gcc-avr avr-libc libsimavr-dev"
    monkeypatch.setattr(simavr_trigger, "simavr_missing", lambda: reason)
    simulator, runs = trigger_simulator(tmp_path)
    try:
        assert isinstance(simulator, TriggerSimulator)
        assert runs == f"a serial fake of the trigger firmware's protocol ({reason})"
        with ArduinoTrigger(str(simulator.link), boot_s=1.0) as driver:
            driver.arm()
            assert simulator.pulse() is True
    finally:
        simulator.close()


@pytest.mark.skipif(MISSING is not None, reason=f"{MISSING} (.ci/run installs them)")
def test_a_simulation_that_stopped_is_a_device_error(tmp_path):
    from sassi_bench.errors import DeviceError

    simulator = SimavrTrigger(tmp_path)
    simulator.proc.kill()
    simulator.proc.wait()
    try:
        with pytest.raises(DeviceError, match="trigger firmware in simavr: the simulation stopped"):
            simulator.pulse()
    finally:
        simulator.close()
