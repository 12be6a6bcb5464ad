"""publish_derived: a child bundle carries its parent's record."""

import numpy as np
import pytest

from sassi_bench.bundle import BundleError, BundleQualityError, QualityCheck, load
from sassi_bench.bundle.derive import derived_checks, publish_derived, stage_checks


def test_a_child_of_a_passing_parent_passes_and_keeps_its_models(published, synthetic):
    parent = load(published)
    response = np.linspace(0.5, 1.0, parent.wavelengths.size)
    child = load(
        publish_derived(
            parent, stage="response", rig=synthetic.RIG, models={"response": response},
            checks=[QualityCheck.at_most("spread", 0.02, 0.1, "1")],
            residuals={"spread": 0.02}, procedure={"response": {"light": "halogen"}},
            inputs=[{"id": "white", "sha256": "cd" * 32}], data=published.parents[1],
        )
    )  # fmt: skip
    assert child.passed and not child.override and child.version == "v0002"
    assert np.array_equal(child.response, response)
    assert np.array_equal(child.guide_to_slm, parent.guide_to_slm)
    names = [c["name"] for c in child.manifest["quality"]["checks"]]
    assert names == ["dispersion_rms", "homography_rms", "macbeth_psnr", "response.spread"]
    quality = child.manifest["quality"]
    assert quality["residuals"]["response"] == {"spread": 0.02}
    assert quality["residuals"]["laser_x_rms_px"] == (0.07, 0.08, 0.09, 0.06, 0.1)
    assert quality["derived_from"]["version"] == "v0001"
    assert child.manifest["procedure"]["lasers_nm"] == (450, 520, 532, 635, 670)
    assert [i["id"] for i in child.manifest["inputs"]] == ["laser-sweep-2024-05-01", "white"]


def test_a_failed_parent_needs_allow_failed_and_makes_a_failed_child(data_root, synthetic):
    parent = load(
        synthetic.publish_synthetic(
            data_root, quality=synthetic.failing_quality(), allow_failed=True
        )
    )
    kwargs = {"stage": "guide", "rig": synthetic.RIG, "data": data_root}
    with pytest.raises(BundleQualityError, match=r"dispersion_rms.*--allow-failed"):
        publish_derived(parent, **kwargs)
    child = load(publish_derived(parent, allow_failed=True, **kwargs))
    assert not child.passed and child.override
    assert child.manifest["quality"]["derived_from"]["override"] is True


def test_a_stage_supersedes_its_own_earlier_checks(published):
    parent = load(published)
    first = stage_checks("guide", [QualityCheck.at_most("rms", 0.9, 0.5, "px")])
    assert [c.name for c in first] == ["guide.rms"]
    # As if the parent had a failed guide check: the new measurement replaces it.
    checks = derived_checks(parent, "macbeth", [QualityCheck.at_most("de00", 0.2, 1, "1")])
    assert [c.name for c in checks][-1] == "macbeth.de00"
    with pytest.raises(BundleError, match="stage name"):
        stage_checks("Guide Camera", first)
