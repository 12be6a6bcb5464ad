"""Hardware rig descriptions and how a rig opens its devices."""

import json

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.errors import ConfigError, DeviceError
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict


@pytest.fixture()
def lab_dict():
    return load_rig_description("lab-example").to_dict()


def test_lab_example_describes_a_real_bench(lab_dict):
    desc = load_rig_description("lab-example")
    assert desc.backend == "hardware"
    assert desc.hardware["trigger"]["kind"] == "arduino"
    assert desc.hardware["spectral_camera"]["kind"] == "dcam"
    assert desc.hardware["guide_camera"]["device"] == {"serial_number": "REPLACE-ME"}
    assert rig_description_from_dict(lab_dict).sha256() == desc.sha256()
    assert "hardware" not in load_rig_description("sim").to_dict()  # sim hashes unchanged


def test_rig_hash_ignores_where_devices_are_plugged_in(lab_dict):
    before = rig_description_from_dict(lab_dict).sha256()
    lab_dict["hardware"]["trigger"]["port"] = "/dev/ttyACM1"
    lab_dict["hardware"]["slm"]["monitor"] = 2
    lab_dict["hardware"]["guide_camera"]["cti"] = "/usr/lib/gentl/other.cti"
    assert rig_description_from_dict(lab_dict).sha256() == before
    lab_dict["hardware"]["guide_camera"]["device"] = {"serial_number": "20999999"}
    assert rig_description_from_dict(lab_dict).sha256() != before  # another camera


def test_backend_and_section_must_agree(lab_dict, sim_dict):
    del lab_dict["hardware"]
    with pytest.raises(ConfigError, match="backend 'hardware' needs a hardware section"):
        rig_description_from_dict(lab_dict)
    sim_dict["hardware"] = load_rig_description("lab-example").hardware
    with pytest.raises(ConfigError, match="only read with backend 'hardware'"):
        rig_description_from_dict(sim_dict)


@pytest.mark.parametrize(
    ("path", "value", "match"),
    [
        (("guide_camera", "kind"), "gige", "hardware.guide_camera.kind"),
        (("guide_camera", "cti"), None, "hardware.guide_camera"),
        (("spectral_camera", "cti"), "x.cti", "hardware.spectral_camera"),
        (("trigger", "baudrate"), 12, "hardware.trigger.baudrate"),
        (("slm", "screen"), 1, "hardware.slm"),
    ],
)
def test_hardware_section_is_validated(lab_dict, path, value, match):
    section = lab_dict["hardware"][path[0]]
    if value is None:
        del section[path[1]]
    else:
        section[path[1]] = value
    with pytest.raises(ConfigError, match=match):
        rig_description_from_dict(lab_dict)


def test_a_hardware_rig_opens_every_adapter(sim_dict, simavr_trigger, dummy_x, viky_cti):
    from sassi_bench.rig.hardware.build import build_hardware_rig

    sim_dict["backend"] = "hardware"
    camera = {"kind": "genicam", "cti": viky_cti, "trigger": "none"}
    sim_dict["hardware"] = {
        "trigger": {"kind": "arduino", "port": simavr_trigger.port, "boot_s": 5.0},
        "slm": {"kind": "display", "monitor": "DUMMY1"},
        "spectral_camera": {**camera, "device": {"serial_number": "0"}, "pixel_format": "Mono8"},
        "guide_camera": {**camera, "device": 1, "pixel_format": "RGBa8"},
    }
    wrong = json.loads(json.dumps(sim_dict))
    wrong["hardware"]["guide_camera"]["device"] = {"serial_number": "9"}
    with pytest.raises(DeviceError, match=r"guide camera: no camera matches .*serial_number"):
        build_hardware_rig(rig_description_from_dict(wrong), prompt=print)
    # the failed attempt released the trigger, the SLM window and the spectral camera
    asked = []
    rig = build_hardware_rig(rig_description_from_dict(sim_dict), prompt=asked.append)
    try:
        assert rig.trigger.counters() == {"received": 0, "passed": 0}
        rig.light.select("laser:532")
        rig.set_scene("colorchecker")
        pid = rig.slm.show(np.zeros(rig.slm.shape, bool))
        frame = rig.guide_camera.capture()
        assert frame.shape == (400, 400, 3)
        assert (frame.meta.pattern_id, frame.meta.light) == (pid, "laser:532")
        assert rig.spectral_camera.capture().shape == (400, 400)
        assert asked == [
            "Switch on the 532 nm laser only",
            "Place the colorchecker target in front of the camera",
        ]
    finally:
        rig.spectral_camera.close()
        rig.guide_camera.close()
        rig.slm.close()
        rig.trigger.close()


def test_opening_the_lab_rig_without_its_arduino_names_the_port(lab_dict, tmp_path):
    lab_dict["hardware"]["trigger"]["port"] = str(tmp_path / "ttyACM0")
    with pytest.raises(DeviceError, match=r"trigger connect: cannot open serial port .*ttyACM0"):
        open_rig(rig_description_from_dict(lab_dict))
