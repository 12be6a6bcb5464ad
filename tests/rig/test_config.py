import pytest

from sassi_bench.errors import ConfigError
from sassi_bench.rig.config import (
    available_rigs,
    load_rig_description,
    rig_description_from_dict,
)


def test_shipped_rigs_load_with_their_scales():
    assert {"sim", "sim-prototype"} <= set(available_rigs())
    sim = load_rig_description("sim")
    assert (sim.slm.width, sim.slm.height) == (640, 400)
    assert (sim.spectral_camera.width, sim.spectral_camera.height) == (800, 512)
    assert sim.prism.spread_px == 68
    proto = load_rig_description("sim-prototype")
    assert (proto.slm.width, proto.slm.height) == (1920, 1080)
    assert (proto.spectral_camera.width, proto.spectral_camera.height) == (2048, 2048)


def test_round_trip_through_dict_is_stable():
    sim = load_rig_description("sim")
    again = rig_description_from_dict(sim.to_dict())
    assert again.to_dict() == sim.to_dict()
    assert again.sha256() == sim.sha256()


def test_unknown_key_is_named_with_a_suggestion(sim_dict):
    sim_dict["slm"]["widht"] = 640
    with pytest.raises(ConfigError, match=r"slm\.widht: unknown key.*did you mean 'width'"):
        rig_description_from_dict(sim_dict)


def test_unknown_top_level_key_is_named(sim_dict):
    sim_dict["lasers"] = [450]
    with pytest.raises(ConfigError, match=r"lasers: unknown key.*lasers_nm"):
        rig_description_from_dict(sim_dict)


@pytest.mark.parametrize(
    ("section", "key", "value", "pattern"),
    [
        ("prism", "apex_deg", 120, r"prism\.apex_deg: 120 is greater than the maximum"),
        ("slm", "width", -5, r"slm\.width: -5 is less than the minimum"),
        ("spectral_camera", "bit_depth", 24, r"spectral_camera\.bit_depth"),
        ("relay", "scale", "big", r"relay\.scale: 'big' is not of type 'number'"),
        ("relay", "offset_px", [1.0], r"relay\.offset_px"),
        ("slm", "contrast_ratio", 1, r"slm\.contrast_ratio"),
    ],
)
def test_impossible_values_name_the_key(sim_dict, section, key, value, pattern):
    sim_dict[section][key] = value
    with pytest.raises(ConfigError, match=pattern):
        rig_description_from_dict(sim_dict)


def test_missing_section_is_reported(sim_dict):
    del sim_dict["prism"]
    with pytest.raises(ConfigError, match="'prism' is a required property"):
        rig_description_from_dict(sim_dict)


def test_blur_needs_three_points(sim_dict):
    sim_dict["blur"]["sigma_px"] = {"450": 1.0, "600": 1.0}
    with pytest.raises(ConfigError, match=r"blur\.sigma_px"):
        rig_description_from_dict(sim_dict)


def test_unknown_glass_is_rejected(sim_dict):
    sim_dict["prism"]["glass"] = "BK-7000"
    with pytest.raises(ConfigError, match=r"prism\.glass"):
        rig_description_from_dict(sim_dict)


def test_streaks_that_do_not_fit_the_camera_are_rejected(sim_dict, make_rig):
    sim_dict["relay"]["scale"] = 1.4
    with pytest.raises(ConfigError, match=r"relay: .*outside the 800x512 camera"):
        make_rig(sim_dict)


def test_bad_files_give_clear_errors(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("slm: [unclosed\n")
    with pytest.raises(ConfigError, match="not valid YAML"):
        load_rig_description(bad)
    listing = tmp_path / "list.yaml"
    listing.write_text("- 1\n- 2\n")
    with pytest.raises(ConfigError, match="expected a mapping"):
        load_rig_description(listing)
    with pytest.raises(ConfigError, match="no such file"):
        load_rig_description(tmp_path / "missing.yaml")
    with pytest.raises(ConfigError, match="unknown rig 'nonesuch'"):
        load_rig_description("nonesuch")


def test_yaml_file_of_a_custom_rig_loads(tmp_path, sim_dict):
    import yaml

    sim_dict["name"] = "my-bench"
    sim_dict["prism"]["glass"] = "F2"
    path = tmp_path / "my-bench.yaml"
    path.write_text(yaml.safe_dump(sim_dict))
    desc = load_rig_description(path)
    assert desc.name == "my-bench"
    assert desc.prism.glass == "F2"
    assert desc.source == str(path)


def test_a_folder_named_like_a_rig_does_not_shadow_it(tmp_path, monkeypatch):
    # The data root keeps each rig's bundles in a folder named after the rig.
    (tmp_path / "sim").mkdir()
    monkeypatch.chdir(tmp_path)
    assert load_rig_description("sim").name == "sim"
