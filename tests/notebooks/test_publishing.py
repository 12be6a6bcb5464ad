"""A notebook publishes a fit once, and says which bundle ``latest`` is."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

from sassi_bench.bundle import load
from sassi_bench.notebook import latest_summary, publish_once

_CONFTEST = Path(__file__).resolve().parents[1] / "bundle" / "conftest.py"
_spec = importlib.util.spec_from_file_location("bundle_synthetic", _CONFTEST)
synthetic = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = synthetic
_spec.loader.exec_module(synthetic)


def test_the_same_models_are_published_once(tmp_path: Path, capsys):
    models = synthetic.make_models()
    first = publish_once(models, lambda: synthetic.publish_synthetic(tmp_path), rig="sim", data=tmp_path)
    said = capsys.readouterr().out
    assert first.name == "v0001"
    assert "published sim/v0001 (dispersion, blur, guide homography, radiometric response)" in said
    assert "latest: sim/v0001" in said

    spectral_only = synthetic.make_models(guide_to_slm=None, guide_info={}, response=None)
    publish_once(
        spectral_only,
        lambda: synthetic.publish_synthetic(tmp_path, models=spectral_only),
        rig="sim",
        data=tmp_path,
    )
    capsys.readouterr()

    def must_not_run():
        raise AssertionError("published again")

    again = publish_once(models, must_not_run, rig="sim", data=tmp_path)
    said = capsys.readouterr().out
    assert again == first and load(again).version == "v0001"
    assert said.startswith("not published again: sim/v0001 already holds exactly these models")
    assert (
        "latest: sim/v0002 (dispersion, blur; no guide homography or radiometric response)" in said
    )
    assert sorted(p.name for p in (tmp_path / "sim").glob("v*")) == ["v0001", "v0002"]


def test_no_bundle_yet_is_said(tmp_path: Path):
    assert latest_summary("sim", tmp_path) == "latest: none (sim has no published bundle)"
