"""The Macbeth report names the bundle it is published in and shows every stage's checks."""

import dataclasses
import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import QualityCheck, load, publish, publish_derived
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.plots.macbeth import localisation_figure, spectra_figure
from sassi_bench.procedure import load_procedure
from sassi_bench.validate.chart import validate_scans
from sassi_bench.validate.report import write_report
from sassi_bench.workflows import full


@pytest.fixture(scope="module")
def validated(chart_scan, patch_procedure):
    _, bundle, _, run = chart_scan
    return validate_scans(run.scan, bundle, patch_procedure)


def _staged_stages(monkeypatch, rig, calibrated, result):
    """Stand-ins for the chain's stages: each publishes a staging version as the real one
    would (spectral v0001, response v0002, guide v0003), without new scans."""

    def spectral(rig_, proc, *, session_id, data, progress, allow_failed):
        path = publish(
            calibrated.models, rig=rig.description, quality=thaw(calibrated.manifest["quality"]),
            procedure=thaw(calibrated.manifest["procedure"]), data=data, allow_failed=True,
        )  # fmt: skip
        # A figure as the real stage publishes one (the report links it).
        return SimpleNamespace(checks=[], figures={"map": b"\x89PNG stand-in"}, bundle_path=path)

    def response(rig_, parent, *, data, **_):
        uniform = QualityCheck.at_most("white_uniformity", 0.014, 0.1, "1")
        return publish_derived(parent, stage="response", rig=rig.description,
                               checks=[uniform], data=data)  # fmt: skip

    def guide(rig_, parent, proc, *, session_id, data, progress, allow_failed):
        checks = [QualityCheck.at_least("guide_inliers", 147, 30, "1")]
        path = publish_derived(parent, stage="guide", rig=rig.description, checks=checks,
                               data=data)  # fmt: skip
        return SimpleNamespace(checks=checks, figures={}, bundle_path=path)

    def macbeth(rig_, bundle, proc, *, session_id, data, progress):
        plan = Plan("chart", [Step("spectral", "led", 0.1, {"kind": "blank"})])
        chart = Session.create(rig.description, plan, session_id=session_id, data=data)
        settings = {**result.settings, "chart_session": chart.id}
        return dataclasses.replace(result, settings=settings)

    monkeypatch.setattr("sassi_bench.workflows.full.run_spectral_calibration", spectral)
    monkeypatch.setattr("sassi_bench.workflows.full.run_response", response)
    monkeypatch.setattr("sassi_bench.workflows.full.run_guide_registration", guide)
    monkeypatch.setattr("sassi_bench.workflows.full.run_macbeth", macbeth)


def test_a_chain_bundles_report_names_its_published_version(
    chart_scan, validated, monkeypatch, tmp_path
):
    rig, calibrated, _, _ = chart_scan
    _staged_stages(monkeypatch, rig, calibrated, validated)
    root = tmp_path / "lab"
    procedure = load_procedure("full_calibration")
    outcome = full.run_full_calibration(rig, procedure, session_id="chain", data=root,
                                        progress=False)  # fmt: skip
    bundle = load(outcome.bundle_path)
    assert bundle.version == "v0001"  # the staging versions went up to v0003
    doc = json.loads((bundle.path / "report" / "macbeth_report.json").read_text())
    assert doc["bundle"]["version"] == "v0001" and doc["bundle"]["created"] == bundle.created
    # The scans' bundle is named where it is (the run's staging folder), never as a version
    # of the lab's data root, which would be another bundle.
    staged = "the staged bundle staging/chain/sim/v0003 of this run"
    assert doc["bundle"]["scanned_with"] == staged and doc["bundle"]["models_identical"]
    names = [c["name"] for c in doc["bundle"]["checks"]]
    assert names == [c["name"] for c in bundle.manifest["quality"]["checks"]]
    stages = {name.split(".")[0] for name in names}
    assert stages == {"spectral", "response", "guide", "macbeth"}
    html = (bundle.path / "report" / "macbeth_report.html").read_text()
    assert "validation: sim / v0001</h1>" in html and "v0003</h1>" not in html
    assert "staging version" not in html
    # A person reads the run's own models, not its internal staging folder.
    assert "staging/" not in html and "sim/v0003" not in html
    assert "this calibration run's models before they were published" in html
    assert bundle.created in html
    # Both reports link the bundle's figures: the bundle's own beside it, the copy beside
    # the data into the bundle's folder; apart from those links the copy is the same page.
    copy = root / "reports" / "chain" / "macbeth_report.html"
    figures = sorted(p.name for p in (bundle.path / "report").glob("*.png"))
    assert figures, "the chain publishes its spectral and guide figures"
    for page in (bundle.path / "report" / "macbeth_report.html", copy):
        links = re.findall(r'<li><a href="([^"]+)">', page.read_text())
        assert sorted(Path(link).name for link in links) == figures
        assert all((page.parent / link).resolve().is_file() for link in links)
    unlinked = re.compile(r"<h2>The bundle's figures</h2>.*?</ul>", re.S)
    assert unlinked.sub("", copy.read_text()) == unlinked.sub("", html)
    # No dimensionless value is printed with a unit "1".
    assert not re.search(r"\d 1</td>", html)


def test_a_stand_alone_report_links_the_figures_of_the_bundle_it_validates(
    chart_scan, validated, patch_procedure, tmp_path
):
    _, bundle, _, _ = chart_scan
    figures = sorted(p.name for p in (bundle.path / "report").glob("*.png"))
    assert figures, "the spectral stage publishes its figures"
    page, _ = write_report(validated, bundle, patch_procedure, tmp_path / "lab" / "report")
    links = re.findall(r'<li><a href="([^"]+)">', page.read_text())
    assert sorted(Path(link).name for link in links) == figures
    assert all(not Path(link).is_absolute() for link in links)
    assert all((page.parent / link).resolve().is_file() for link in links)


def test_figure_titles_are_whole_and_count_the_measured_patches(validated):
    fig, _ = spectra_figure(validated)
    titles = [ax.get_title() for ax in fig.axes]
    for k, name in enumerate(validated.patch_names):
        assert titles[k].startswith(f"{k + 1} {name}\n")
    fig, _ = localisation_figure(validated, 0.5)
    title = fig.axes[0].get_title()
    assert title.startswith("Patch localisation: 24 patches")
    assert f"{validated.grid.detected}" in title
