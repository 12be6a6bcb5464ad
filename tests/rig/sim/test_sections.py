"""The bench-only sections of a rig YAML, parsed and checked by the virtual bench alone."""

import pytest
import yaml

from sassi_bench import open_rig
from sassi_bench.errors import ConfigError
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim.sections import (
    AsBuiltConfig,
    NuisanceConfig,
    as_built_section,
    check_bench_sections,
    nuisance_section,
)


def test_as_built_and_nuisance_are_parsed_for_the_virtual_bench(sim_dict, tmp_path):
    curves = tmp_path / "guide.csv"
    curves.write_text("wavelength_nm,r,g,b\n400,0.1,0.2,0.9\n700,0.9,0.1,0.0\n")
    rig_yaml = tmp_path / "rig.yaml"
    sim_dict["as_built"] = {
        "lasers_nm": {"635": 637.8},
        "glass_index_offset": 0.001,
        "apex_deg": 30.2,
        "halogen_k": 2900,
        "led": "LED-B4",
        "guide_sensitivities": "guide.csv",
        "slm_gamma": 2.1,
    }
    sim_dict["nuisance"] = {"laser_power_jitter": 0.01, "speckle_contrast": 0.2}
    rig_yaml.write_text(yaml.safe_dump(sim_dict))
    desc = load_rig_description(rig_yaml)
    check_bench_sections(desc)  # the CSV is found beside the YAML
    as_built, nuisance = as_built_section(desc), nuisance_section(desc)
    assert as_built.lasers_nm == {635.0: 637.8}
    assert (as_built.halogen_k, as_built.slm_gamma) == (2900, 2.1)
    assert nuisance.laser_power_jitter == 0.01 and nuisance.hot_pixels_fraction == 0
    # Defaults: a rig without the sections is as described and clean.
    plain = load_rig_description("sim")
    assert as_built_section(plain) == AsBuiltConfig()
    assert nuisance_section(plain) == NuisanceConfig()


@pytest.mark.parametrize(
    ("value", "pattern"),
    [
        ({"lasers_nm": {"640": 641.0}}, r"as_built\.lasers_nm: 640 nm are not lines"),
        ({"guide_sensitivities": "nowhere.csv"}, r"as_built\.guide_sensitivities: no"),
        ({"guide_sensitivities": "Nikon 5100"}, r"as_built\.guide_sensitivities: unk"),
        ({"led": "LED-X"}, r"as_built\.led: unknown"),
    ],
)
def test_a_virtual_bench_refuses_to_open_with_bad_as_built_values(sim_dict, value, pattern):
    sim_dict["as_built"] = value
    desc = rig_description_from_dict(sim_dict)
    with pytest.raises(ConfigError, match=pattern):
        open_rig(desc)
