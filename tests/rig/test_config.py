import numpy as np
import pytest
import yaml

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
    with pytest.raises(ConfigError, match=r"\(top level\): missing key 'prism'. Fix: add prism"):
        rig_description_from_dict(sim_dict)


def test_blur_needs_three_points(sim_dict):
    sim_dict["blur"]["sigma_px"] = {"450": 1.0, "600": 1.0}
    with pytest.raises(ConfigError, match=r"blur\.sigma_px"):
        rig_description_from_dict(sim_dict)


def test_unknown_glass_is_rejected_with_the_rig_key_that_adds_it(sim_dict):
    sim_dict["prism"]["glass"] = "BK-7000"
    with pytest.raises(ConfigError, match=r"prism\.glass") as refused:
        rig_description_from_dict(sim_dict)
    assert "prism.sellmeier: {b: [B1, B2, B3], c: [C1, C2, C3]}" in str(refused.value)
    assert "sassi_bench." not in str(refused.value)  # nothing to edit in the package


#: SCHOTT N-K5 (a glass the catalogue does not hold), from its data sheet.
N_K5 = {"b": [1.08511833, 0.199562005, 0.930511663], "c": [0.00661099503, 0.024110866, 111.982777]}


def test_a_rig_gives_the_sellmeier_coefficients_of_its_own_glass(sim_dict, make_rig):
    from sassi_bench.optics.glass import sellmeier_index

    sim_dict["prism"].update(glass="N-K5", sellmeier=N_K5)
    sim_dict["relay"]["offset_px"] = [18.0, 3.0]  # N-K5 spreads the blue a little further
    desc = rig_description_from_dict(sim_dict)
    glass = desc.prism.glass_model()
    assert glass.name == "N-K5" and round(glass.nd, 4) == 1.5225 and round(glass.vd, 1) == 59.5
    lam = [450.0, 550.0, 650.0]
    np.testing.assert_allclose(
        desc.nominal_relay().glass.index(lam), sellmeier_index(lam, N_K5["b"], N_K5["c"])
    )
    assert rig_description_from_dict(desc.to_dict()).sha256() == desc.sha256()
    rig = make_rig(sim_dict)  # the virtual bench traces its rays through that glass
    assert rig.description.prism.sellmeier.b == tuple(N_K5["b"])
    # A catalogue glass keeps the description (and its hash) as it was.
    assert "sellmeier" not in load_rig_description("sim").to_dict()["prism"]


def test_coefficients_that_are_no_glass_are_refused(sim_dict):
    sim_dict["prism"].update(glass="N-K5", sellmeier={"b": [-1.0, 0.0, 0.0], "c": [0, 0, 0]})
    with pytest.raises(ConfigError, match=r"prism\.sellmeier: .* not that of an optical glass"):
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

    sim_dict["name"] = "my-bench"
    sim_dict["prism"]["glass"] = "F2"
    sim_dict["relay"]["offset_px"] = [30.0, 3.0]  # F2 spreads the blue further: recentre
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


def _hardware_dict(sim_dict):
    """The sim rig's optics as a real rig (``backend: hardware``) of the lab example."""
    lab = load_rig_description("lab-example").to_dict()
    data = {k: v for k, v in sim_dict.items() if k not in ("light", "scenes")}
    data.update(backend="hardware", hardware=lab["hardware"])
    return data


def test_streaks_off_the_camera_are_refused_at_load_for_every_backend(sim_dict):
    sim_dict["relay"]["offset_px"] = [300.0, 3.0]
    with pytest.raises(ConfigError, match=r"relay: .*spans camera x 286\.\.1072.*800x512 camera"):
        rig_description_from_dict(sim_dict)
    hardware = _hardware_dict(sim_dict)
    with pytest.raises(ConfigError, match=r"relay: .*outside the 800x512 camera"):
        rig_description_from_dict(hardware)


def test_the_streak_check_follows_the_ray_trace(sim_dict):
    # The ray trace puts the sim rig's SLM corner at 400 nm at camera x 11.2 and the spot
    # reaches 3 sigma = 10.7 px (the blur at 700 nm, 3.56 px, with the SLM pixel's
    # aperture): 0.5 px to spare at the shipped offset of 14 px, none at 13.
    assert rig_description_from_dict(sim_dict).relay.offset_px == (14.0, 3.0)
    sim_dict["relay"]["offset_px"] = [13.0, 3.0]
    with pytest.raises(ConfigError, match=r"camera x -1\.\.7\d\d, y 29\.\.487"):
        rig_description_from_dict(sim_dict)


def test_lasers_off_the_spectral_grid_are_refused(sim_dict):
    sim_dict["lasers_nm"] = [450, 520, 532, 635, 780]
    with pytest.raises(ConfigError, match=r"lasers_nm: 780 nm lie outside the spectral grid"):
        rig_description_from_dict(sim_dict)
    sim_dict["spectral_grid"]["stop_nm"] = 800
    assert rig_description_from_dict(sim_dict).lasers_nm[-1] == 780


@pytest.mark.parametrize(
    ("section", "key", "value", "pattern"),
    [
        ("light", "led", "LED-B33", r"light\.led: unknown illuminant 'LED-B33' \(did you mean"),
        ("light", "fluorescent", "FL22", r"light\.fluorescent: unknown illuminant 'FL22'"),
        (
            "guide_camera",
            "sensitivities",
            "Nikon 5100",
            r"guide_camera\.sensitivities: unknown camera sensitivities 'Nikon 5100' "
            r"\(did you mean 'Nikon 5100 \(NPL\)'\?\)",
        ),
        ("spectral_camera", "qe", "scmoss", r"spectral_camera\.qe: unknown curve 'scmoss' \(did"),
        ("spectral_camera", "qe", {"400": 0.5, "700": 1.5}, r"spectral_camera\.qe: .*0 to 1"),
        ("prism", "glass", "N-BK8", r"prism\.glass: unknown glass 'N-BK8' \(did you mean 'N-BK7'"),
        ("scenes", "colorchecker_data", "BabelColor", r"scenes\.colorchecker_data: unknown"),
        ("scenes", "natural_image", "cofee", r"scenes\.natural_image: .*did you mean 'coffee'"),
    ],
)
def test_named_data_are_checked_at_load(sim_dict, section, key, value, pattern):
    sim_dict[section][key] = value
    with pytest.raises(ConfigError, match=pattern):
        rig_description_from_dict(sim_dict)


def test_sim_defaults_apply_to_sim_rigs_only(sim_dict):
    explicit = rig_description_from_dict(sim_dict)
    for section, keys in (
        ("guide_camera", ["sensitivities"]),
        ("light", ["led", "halogen_k", "fluorescent"]),
        ("spectral_camera", ["qe"]),
    ):
        for key in keys:
            del sim_dict[section][key]
    implicit = rig_description_from_dict(sim_dict)
    # A sim rig that leaves them out is the same rig as one that names the bench's parts.
    assert implicit.to_dict() == explicit.to_dict()
    assert implicit.guide_camera.sensitivities == "Nikon 5100 (NPL)"
    assert implicit.light.halogen_k == 3000.0
    hardware = rig_description_from_dict(_hardware_dict(sim_dict))
    assert hardware.guide_camera.sensitivities is None
    assert hardware.light.halogen_k is None and hardware.light.led is None
    assert hardware.spectral_camera.qe is None
    # None survives the round trip through the canonical form a bundle stores.
    assert rig_description_from_dict(hardware.to_dict()).sha256() == hardware.sha256()


def test_the_lab_example_names_no_virtual_bench_part():
    lab = load_rig_description("lab-example")
    assert lab.guide_camera.sensitivities is None and lab.light.halogen_k is None


@pytest.mark.parametrize(
    ("section", "value", "pattern"),
    [
        ("as_built", {"halogen": 2900}, r"as_built\.halogen"),
        ("nuisance", {"slm_crosstalk": 0.5}, r"nuisance\.slm_crosstalk: 0\.5 is greater"),
    ],
)
def test_bench_only_sections_are_held_to_the_schema(sim_dict, section, value, pattern):
    sim_dict[section] = value
    with pytest.raises(ConfigError, match=pattern):
        rig_description_from_dict(sim_dict)


def test_bench_only_sections_are_set_apart_raw(sim_dict):
    sim_dict["nuisance"] = {"stray_light": 0.01}
    desc = rig_description_from_dict(sim_dict)
    assert desc.bench_sections == {"nuisance": {"stray_light": 0.01}}
    assert "nuisance" not in desc.to_dict()
    assert load_rig_description("sim").bench_sections == {}


def test_a_real_rig_refuses_bench_only_sections(sim_dict):
    hardware = _hardware_dict(sim_dict)
    hardware["nuisance"] = {"stray_light": 0.01}
    with pytest.raises(ConfigError, match=r"nuisance: only read by the virtual bench"):
        rig_description_from_dict(hardware)


def test_wavelength_lamps_name_lights_and_drop_out_of_a_lamp_less_rig(sim_dict):
    sim = load_rig_description("sim")
    assert sim.wavelength_lamps == ("HgAr", "Ne")
    assert sim.light_names[-2:] == ("lamp:HgAr", "lamp:Ne")
    sim_dict.pop("wavelength_lamps")
    plain = rig_description_from_dict(sim_dict)
    assert "wavelength_lamps" not in plain.to_dict()
    assert "laser_tolerance_nm" not in plain.to_dict()
    assert plain.sha256() != sim.sha256()


@pytest.mark.parametrize(
    ("lamps", "pattern"),
    [
        (["HgAr", "Hg-Ar"], r"wavelength_lamps: unknown lamp 'Hg-Ar' \(did you mean 'HgAr'\?\)"),
        (["HgAr", "hgar"], r"wavelength_lamps: 'HgAr' and 'hgar' are both lamp 'HgAr'"),
        (["missing.csv"], r"wavelength_lamps: no such file"),
    ],
)
def test_bad_wavelength_lamps_are_refused_naming_the_key(sim_dict, lamps, pattern):
    sim_dict["wavelength_lamps"] = lamps
    with pytest.raises(ConfigError, match=pattern) as error:
        rig_description_from_dict(sim_dict)
    assert str(error.value).startswith("rig description sim: wavelength_lamps: ")


def test_a_lamp_csv_is_found_beside_the_rig_yaml(tmp_path, sim_dict):
    (tmp_path / "argon.csv").write_text("wavelength_nm,relative_intensity\n696.5431,1\n420.07,1\n")
    sim_dict["wavelength_lamps"] = ["argon.csv"]
    path = tmp_path / "rig.yaml"
    path.write_text(yaml.safe_dump(sim_dict))
    desc = load_rig_description(path)
    assert desc.light_names[-1] == "lamp:argon"
    assert list(desc.lamp_lines()) == ["argon"]


def test_laser_tolerance_per_label(sim_dict):
    sim_dict["laser_tolerance_nm"] = {"532": 0.05}
    desc = rig_description_from_dict(sim_dict)
    assert desc.laser_tolerance(532.0) == 0.05 and desc.laser_tolerance(450.0) == 5.0
    assert rig_description_from_dict(desc.to_dict()).sha256() == desc.sha256()
    sim_dict["laser_tolerance_nm"] = {"533": 0.05}
    with pytest.raises(ConfigError, match=r"laser_tolerance_nm: 533 nm is not a line.*'532'"):
        rig_description_from_dict(sim_dict)


def test_hardware_section_errors_read_like_the_optics_ones(sim_dict):
    typo = _hardware_dict(sim_dict)
    typo["hardware"]["guide_camera"]["ct"] = typo["hardware"]["guide_camera"].pop("cti")
    with pytest.raises(ConfigError) as caught:
        rig_description_from_dict(typo)
    message = str(caught.value)
    assert "hardware.guide_camera.ct: unknown key 'ct' (did you mean 'cti'?)" in message
    assert "hardware.guide_camera: missing key 'cti' (kind genicam)" in message
    # The allowed keys are the camera section's, reached through the schema's $ref.
    assert "use one of kind, cti, device, index," in message
    assert "add cti under hardware.guide_camera" in message
    wrong_kind = _hardware_dict(sim_dict)
    wrong_kind["hardware"]["spectral_camera"]["cti"] = "x.cti"
    with pytest.raises(
        ConfigError,
        match=r"hardware\.spectral_camera: 'cti' does not apply \(kind dcam\)\. "
        r"Fix: remove cti from hardware\.spectral_camera",
    ):
        rig_description_from_dict(wrong_kind)
