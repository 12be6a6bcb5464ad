"""Which bundle ``latest`` means to work that needs a model: the newest that has it, said
in words; a bundle named explicitly that lacks it is refused, naming the one that has it."""

from __future__ import annotations

from pathlib import Path

import pytest

from sassi_bench.bundle import BundleError
from sassi_bench.bundle.choice import choose_bundle


def _complete_then_spectral_only(data: Path, synthetic) -> None:
    synthetic.publish_synthetic(data)  # v0001: guide homography and response
    spectral = synthetic.make_models(guide_to_slm=None, guide_info={}, response=None)
    synthetic.publish_synthetic(data, models=spectral)  # v0002, LATEST


def test_latest_is_the_newest_bundle_with_what_the_work_needs(data_root: Path, synthetic):
    _complete_then_spectral_only(data_root, synthetic)
    assert (data_root / "sim" / "LATEST").read_text().strip() == "v0002"
    snapshot = choose_bundle("latest", rig="sim", data=data_root, needs=("guide_homography",))
    assert snapshot.name == "sim/v0001"
    assert snapshot.reason == (
        "the newest with a guide -> SLM homography; the latest, sim/v0002, has no guide -> "
        "SLM homography"
    )
    scan = choose_bundle("latest", rig="sim", data=data_root, wants=("response",))
    assert scan.name == "sim/v0002"
    assert scan.reason == "latest; it has no radiometric response: sim/v0001 has one"


def test_a_named_bundle_that_lacks_a_needed_model_is_refused_naming_one_that_has_it(
    data_root: Path, synthetic
):
    _complete_then_spectral_only(data_root, synthetic)
    with pytest.raises(BundleError) as refused:
        choose_bundle(
            "v0002", rig="sim", data=data_root, needs=("guide_homography",), step="snapshot take"
        )
    message = str(refused.value)
    assert message.startswith("snapshot take: bundle sim/v0002 has no guide -> SLM homography")
    assert "use sim/v0001, which has one (--bundle v0001)" in message
    assert "Session." not in message and "sassi_bench." not in message
