"""``rig check``: every device looked at in turn, each finding with its fix, nothing
stopping at the first failure."""

from __future__ import annotations

import dataclasses

import numpy as np

from sassi_bench.rig import check_rig, open_rig
from sassi_bench.rig.base import CameraBase, Exposure, TriggerBase
from sassi_bench.rig.device_check import check_devices, devices_of, virtual_findings


def by_device(report):
    found = {}
    for finding in report.findings:
        found.setdefault(finding.device, []).append(finding)
    return found


def test_the_virtual_bench_reports_its_devices_and_measures_them():
    report = check_rig("sim")
    assert report.ok and report.failed_devices() == []
    found = by_device(report)
    assert list(found) == ["trigger", "SLM", "spectral camera", "guide camera", "lights"]
    assert found["SLM"][0].text == "virtual SLM 640x400"
    # The virtual SLM pulses once per pattern: the three shown while armed all pass.
    assert "3 SLM pulses received, 3 passed" in found["trigger"][1].text
    spectral = found["spectral camera"][-1].text
    # The sim rig's dark offset is 100 ADU; a closed SLM with the light off reads it.
    assert "dark level 100.0 ADU (the rig says 100), 0.00 % saturated" in spectral
    assert "laser:532" in found["lights"][0].text


def test_a_bench_with_nothing_plugged_in_reports_every_device_with_its_fix(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    report = check_rig("lab-example")
    assert not report.ok
    assert report.failed_devices() == ["trigger", "SLM", "spectral camera", "guide camera"]
    found = by_device(report)
    trigger = found["trigger"][0]
    assert "cannot open serial port" in trigger.text and "hardware.trigger.port" in trigger.fix
    assert "FLIR_GenTL.cti" in found["guide camera"][0].text
    assert found["guide camera"][0].fix.startswith("install the camera vendor's SDK")
    assert found["spectral camera"][0].fix  # DCAM-API, or the package to install
    assert found["lights"][0].status == "ok" and "operator" in found["lights"][0].text
    assert all("\n" not in line for line in report.lines())


class _Camera(CameraBase):
    """A camera whose frames are all at one level."""

    def __init__(self, shape, bits, level):
        super().__init__("spectral", shape, bits, (1e-4, 1.0), 0.01)
        self._level = level

    def _expose(self):
        return Exposure(np.full(self.shape, self._level, np.uint16), None, "off")


class _DeadTrigger(TriggerBase):
    """A trigger no SLM pulse reaches."""

    def _arm(self, armed):
        pass

    def _set_divider(self, n):
        pass

    def counters(self):
        return {"received": 0, "passed": 0}


def test_wrong_sizes_saturation_and_a_silent_trigger_are_each_reported():
    rig = open_rig("sim")
    devices = devices_of(rig)
    devices["spectral_camera"] = _Camera((512, 800), 16, 65535)  # saturated
    devices["guide_camera"] = _Camera((300, 600), 12, 20)  # wrong size, grey frames
    devices["trigger"] = _DeadTrigger()
    desc = rig.description
    desc = dataclasses.replace(
        desc, spectral_camera=dataclasses.replace(desc.spectral_camera, exposure_range_s=(1e-5, 5))
    )
    report = check_devices(desc, devices, virtual_findings(rig))
    found = by_device(report)
    assert report.failed_devices() == ["trigger", "guide camera"]
    trigger = found["trigger"][-1]
    assert trigger.status == "fail" and "0 SLM pulses received" in trigger.text
    assert "D2" in trigger.fix
    warns = [f for f in found["spectral camera"] if f.status == "warn"]
    assert any("100.00 % saturated" in f.text for f in warns)
    assert any("exposure 0.0001..1 s, the rig allows 1e-05..5 s" in f.text for f in warns)
    assert any(f.fix.startswith("shorten the exposure") for f in warns)
    guide = [f for f in found["guide camera"] if f.status == "fail"]
    assert guide[0].text == "frames are 600x300, the rig says 600x400"
    assert "guide_camera.width and height" in guide[0].fix


def test_a_device_fault_during_a_check_does_not_stop_the_others():
    rig = open_rig("sim")
    devices = devices_of(rig)

    class Broken(_Camera):
        def _expose(self):
            raise OSError("USB link reset")

    devices["spectral_camera"] = Broken((512, 800), 16, 0)
    report = check_devices(rig.description, devices, virtual_findings(rig))
    assert report.failed_devices() == ["spectral camera"]
    assert "OSError: USB link reset" in by_device(report)["spectral camera"][-1].text
    assert by_device(report)["guide camera"][-1].status == "ok"  # checked after it


def test_the_command_ends_with_what_to_run_next(capsys, monkeypatch):
    from sassi_bench.commands import main

    assert main(["rig", "check", "--rig", "sim"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("rig check: sim (procedures/rigs/sim.yaml), backend sim")
    assert "every device answered" in out
    assert "next: sassi-bench align --rig sim" in out
    monkeypatch.delenv("DISPLAY", raising=False)
    assert main(["rig", "check", "--rig", "lab-example"]) == 1
    out = capsys.readouterr().out
    assert "4 device(s) need attention: trigger, SLM, spectral camera, guide camera" in out
    assert "rig check --rig lab-example --simulate" in out
