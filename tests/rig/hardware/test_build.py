"""Hardware rig descriptions and how a rig opens its devices."""

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


def test_opening_the_lab_rig_without_its_arduino_names_the_port(lab_dict, tmp_path):
    lab_dict["hardware"]["trigger"]["port"] = str(tmp_path / "ttyACM0")
    with pytest.raises(DeviceError, match=r"trigger connect: cannot open serial port .*ttyACM0"):
        open_rig(rig_description_from_dict(lab_dict))
