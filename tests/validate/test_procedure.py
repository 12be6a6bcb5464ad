"""The shipped Macbeth procedure, and edited ones the schema refuses."""

import pytest
import yaml

from sassi_bench.errors import ConfigError
from sassi_bench.procedure import load_procedure


def test_shipped_procedure_has_the_issue_tolerances():
    proc = load_procedure("macbeth_validation")
    assert proc["tolerances"]["mean_de00"] == 1.0
    assert proc["tolerances"]["max_de00"] == 2.5
    assert proc["tolerances"]["mean_spectral_angle_deg"] == 2.0
    assert proc["white_reference"]["source"] in ("diffuser", "patch")


@pytest.mark.parametrize(
    ("section", "key", "value"),
    [
        ("white_reference", "source", "sky"),
        ("localisation", "interior", 0.95),
        ("tolerances", "mean_de00", -1),
    ],
)
def test_bad_values_are_refused_naming_the_key(tmp_path, section, key, value):
    proc = load_procedure("macbeth_validation")
    proc.pop("source")
    proc[section][key] = value
    path = tmp_path / "macbeth.yaml"
    path.write_text(yaml.safe_dump(proc))
    with pytest.raises(ConfigError, match=f"{section}.{key}"):
        load_procedure("macbeth_validation", path)
