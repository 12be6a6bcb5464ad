"""The trigger firmware (in simavr) and its serial driver; the pty fake for link faults."""

import os

import pytest
import serial

from sassi_bench.errors import DeviceError
from sassi_bench.rig.hardware.trigger import ArduinoTrigger


def raw_exchange(device, lines):
    with serial.Serial(device.port, 115200, timeout=2) as link:
        device.reset()  # as an Uno does when the port opens
        assert link.readline().endswith(b"READY SASSI-TRIGGER 1\n")
        replies = []
        for line in lines:
            link.write(line.encode() + b"\n")
            replies.append(link.readline().decode().strip())
        return replies


def test_firmware_line_protocol(simavr_trigger):
    replies = raw_exchange(
        simavr_trigger,
        [
            "ID?",
            "div 7",
            "DIV?",
            "STATE?",
            "ARM",
            "STATE?",
            "DIV 0",
            "DIV 65536",
            "DIV x",
            "FIRE",
            "X" * 40,
            "CNT?",
            "RST",
            "DISARM",
            "STATE?",
        ],
    )
    assert replies == [
        "SASSI-TRIGGER 1 ATMEGA328P",
        "OK",
        "DIV 7",
        "STATE 0 7",
        "OK",
        "STATE 1 7",
        "ERR divider must be an integer in 1..65535",
        "ERR divider must be an integer in 1..65535",
        "ERR divider must be an integer in 1..65535",
        "ERR unknown command",
        "ERR line too long",
        "CNT 0 0",
        "OK",
        "OK",
        "STATE 0 7",
    ]


def test_firmware_gates_every_nth_pulse_to_the_cameras(simavr_trigger):
    with ArduinoTrigger(simavr_trigger.port) as trigger:
        assert trigger.identity == "SASSI-TRIGGER 1 ATMEGA328P"
        simavr_trigger.pulse(2)  # disarmed: counted, not passed
        assert trigger.counters() == {"received": 2, "passed": 0}
        trigger.set_divider(3)
        trigger.arm()
        simavr_trigger.pulse(7)
        assert trigger.counters() == {"received": 9, "passed": 2}
        assert simavr_trigger.camera_pulses == 2
        assert simavr_trigger.outputs[-1] == 0  # the gate closes with the SLM pulse
        trigger.disarm()
        simavr_trigger.pulse(3)
        assert trigger.counters() == {"received": 12, "passed": 2}
        assert simavr_trigger.camera_pulses == 2
        trigger.reset_counters()
        assert trigger.counters() == {"received": 0, "passed": 0}


def test_driver_restores_state_after_a_device_reset(simavr_trigger):
    with ArduinoTrigger(simavr_trigger.port) as trigger:
        trigger.set_divider(2)
        trigger.arm()
        simavr_trigger.reset()
        with pytest.warns(RuntimeWarning, match="restarted: state restored"):
            assert trigger.counters() == {"received": 0, "passed": 0}
        assert trigger.query("STATE?") == "STATE 1 2"
        simavr_trigger.pulse(4)
        assert trigger.counters() == {"received": 4, "passed": 2}
        assert trigger.resets == 1


def test_driver_reports_refused_commands(simavr_trigger):
    with ArduinoTrigger(simavr_trigger.port) as trigger:
        with pytest.raises(DeviceError, match=r"trigger FIRE: the device refused the command"):
            trigger.query("FIRE")
        with pytest.raises(ValueError, match="trigger divider"):
            trigger.set_divider(0)
        assert trigger.query("DIV?") == "DIV 1"


def test_missing_port_names_the_fix(tmp_path):
    with pytest.raises(DeviceError) as err:
        ArduinoTrigger(str(tmp_path / "ttyACM9"))
    message = str(err.value)
    assert message.startswith("trigger connect: cannot open serial port")
    assert "hardware.trigger.port" in message and "dialout" in message


def test_silent_device_names_the_fix(fake_trigger):
    fake_trigger.silent = True
    with pytest.raises(DeviceError, match=r"no answer from .* within 0.3 s\. Fix: flash"):
        ArduinoTrigger(str(fake_trigger.link), timeout_s=0.1, boot_s=0.3)


def test_foreign_device_is_refused(fake_trigger):
    fake_trigger.identity = "Marlin 2.1"
    with pytest.raises(DeviceError, match=r"answered 'Marlin 2.1', not 'SASSI-TRIGGER 1'"):
        ArduinoTrigger(str(fake_trigger.link), timeout_s=0.1, boot_s=0.3)


def test_driver_syncs_state_on_connect_and_reconnects(fake_trigger):
    fake_trigger.armed = True  # left armed by an earlier session
    trigger = ArduinoTrigger(str(fake_trigger.link), timeout_s=0.2, boot_s=1.0)
    assert not fake_trigger.armed and fake_trigger.divider == 1
    trigger.set_divider(3)
    trigger.arm()
    fake_trigger.replug()  # USB dropped, the device came back on a new pty
    assert os.readlink(fake_trigger.link) == fake_trigger.slave_path
    assert trigger.counters() == {"received": 0, "passed": 0}
    assert fake_trigger.armed and fake_trigger.divider == 3
    for _ in range(6):
        fake_trigger.pulse()
    assert trigger.counters() == {"received": 6, "passed": 2}
    trigger.close()


def test_device_that_goes_silent_mid_session(fake_trigger):
    trigger = ArduinoTrigger(str(fake_trigger.link), timeout_s=0.1, boot_s=0.3)
    fake_trigger.silent = True
    with pytest.raises(DeviceError, match=r"no answer from .*\. Fix: flash the trigger firmware"):
        trigger.counters()
