"""A bundle holding exactly some models is found; any change to a model is not the same."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from sassi_bench.bundle.sameness import model_fingerprint, same_models_version


def test_the_bundle_holding_the_same_models_is_found(data_root: Path, synthetic):
    synthetic.publish_synthetic(data_root)
    other = synthetic.make_models(response=None)
    synthetic.publish_synthetic(data_root, models=other)
    assert same_models_version(synthetic.make_models(), rig="sim", data=data_root) == "v0001"
    assert same_models_version(other, rig="sim", data=data_root) == "v0002"


def test_a_changed_array_or_parameter_or_model_is_not_the_same(data_root: Path, synthetic):
    synthetic.publish_synthetic(data_root)
    models = synthetic.make_models()
    changed_array = dataclasses.replace(models, guide_to_slm=models.guide_to_slm * 1.000001)
    changed_blur = synthetic.make_models(blur=type(models.blur)((1.0, 0.0, 2.0), 520.0, 100.0, 2.5))
    without_guide = synthetic.make_models(guide_to_slm=None, guide_info={})
    for different in (changed_array, changed_blur, without_guide):
        assert same_models_version(different, rig="sim", data=data_root) is None


def test_the_guide_homographys_record_is_not_part_of_the_model(data_root: Path, synthetic):
    synthetic.publish_synthetic(data_root)
    models = synthetic.make_models(guide_info={"rms_px": 0.5})
    assert same_models_version(models, rig="sim", data=data_root) == "v0001"


def test_the_fingerprint_is_what_the_writer_stores(published: Path, synthetic):
    manifest = json.loads((published / "manifest.json").read_text())
    fingerprint = model_fingerprint(synthetic.make_models())
    for name, sha in fingerprint["arrays"].items():
        assert manifest["arrays"][name]["sha256"] == sha
    assert set(fingerprint["arrays"]) < set(manifest["arrays"])  # extra arrays are not models


def test_a_damaged_or_missing_manifest_counts_as_different(data_root: Path, synthetic):
    path = synthetic.publish_synthetic(data_root)
    (path / "manifest.json").write_text("{not json")
    assert same_models_version(synthetic.make_models(), rig="sim", data=data_root) is None
    assert same_models_version(synthetic.make_models(), rig="other", data=data_root) is None
