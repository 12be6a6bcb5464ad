"""Bundles derived from a parent (response, guide) carry the parent's checks and status."""

import pytest

from sassi_bench.bundle import BundleQualityError, QualityCheck, load, publish
from sassi_bench.workflows.scan import run_response

FAILED = QualityCheck.at_most("spectral.leave_one_out_rms_nm", 0.9, 0.25, "nm")


def publish_failed_copy(bundle, rig, data):
    """``bundle``'s models published again with a failing check (an override)."""
    return load(
        publish(
            bundle.models,
            rig=rig.description,
            quality={"checks": [FAILED]},
            procedure={"lasers_nm": [450, 520, 532, 635, 670]},
            inputs=[{"id": "sweep", "sha256": "ab" * 32}],
            allow_failed=True,
            data=data,
        )
    )


@pytest.fixture(scope="module")
def failed_parent(calibrated_sim, tmp_path_factory):
    rig, _, data = calibrated_sim
    root = tmp_path_factory.mktemp("failed-parent")
    return rig, publish_failed_copy(load(rig="sim", data=data), rig, root), root


def test_a_failed_parent_is_refused_before_anything_is_captured(failed_parent):
    rig, parent, root = failed_parent
    with pytest.raises(BundleQualityError, match=r"parent bundle sim/v0001 failed.*allow-failed"):
        run_response(rig, parent, session_id="refused", data=root, progress=False)
    assert not (root / "sessions" / "refused").exists()


def test_a_response_bundle_carries_the_parents_failure(failed_parent):
    rig, parent, root = failed_parent
    child = load(
        run_response(rig, parent, every=50, session_id="resp", data=root, progress=False,
                     allow_failed=True)
    )  # fmt: skip
    assert not child.passed and child.override
    checks = {c["name"]: c for c in child.manifest["quality"]["checks"]}
    assert not checks[FAILED.name]["passed"]
    assert {"response.response_positive", "response.white_uniformity"} <= set(checks)
    derived = child.manifest["quality"]["derived_from"]
    assert (derived["version"], derived["passed"]) == ("v0001", False)
    ids = [i["id"] for i in child.manifest["inputs"]]
    assert ids == ["sweep", "resp"]
