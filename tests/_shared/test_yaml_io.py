"""The YAML loader: a mapping, or an error that names the file, the cause and the fix."""

from __future__ import annotations

from importlib import resources

import pytest

from sassi_bench._shared.yaml_io import load_yaml_mapping
from sassi_bench.errors import ConfigError

FIXES = {"missing_fix": "check the path", "mapping_fix": "write keys"}


def test_a_mapping_loads(tmp_path):
    file = tmp_path / "p.yaml"
    file.write_text("name: lab\nlasers_nm: [450, 532]\n", encoding="utf-8")
    assert load_yaml_mapping(file, "procedure", **FIXES) == {
        "name": "lab",
        "lasers_nm": [450, 532],
    }


def test_a_shipped_file_loads_by_resource():
    file = resources.files("sassi_bench.procedures").joinpath("rigs", "sim.yaml")
    assert load_yaml_mapping(file, "rig description", **FIXES)["name"] == "sim"


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(ConfigError) as caught:
        load_yaml_mapping(tmp_path / "nope.yaml", "procedure", **FIXES)
    assert str(caught.value) == (
        f"procedure {tmp_path / 'nope.yaml'}: no such file. Fix: check the path"
    )


def test_broken_yaml_names_the_line(tmp_path):
    file = tmp_path / "bad.yaml"
    file.write_text("slm: [unclosed\n")
    with pytest.raises(ConfigError, match=r"procedure bad.yaml: not valid YAML \(.*line 2"):
        load_yaml_mapping(file, "procedure", label="bad.yaml", **FIXES)


@pytest.mark.parametrize(
    ("text", "got"), [("- 1\n- 2\n", "list"), ("", "an empty file"), ("42\n", "int")]
)
def test_a_top_level_that_is_not_a_mapping_is_refused(tmp_path, text, got):
    file = tmp_path / "odd.yaml"
    file.write_text(text)
    with pytest.raises(ConfigError) as caught:
        load_yaml_mapping(file, "rig description", label="odd.yaml", **FIXES)
    assert str(caught.value) == (
        f"rig description odd.yaml: expected a mapping of keys at the top level, got {got}. "
        "Fix: write keys"
    )
