"""The guided notebooks clicked through in JupyterLab by a headless Chromium.

Each test runs a notebook cell by cell from the keyboard, changes its widgets by clicking
and typing, and checks the effect on what the kernel holds, on the figures it shows and on
what is published or written under the data root, scored against the bench's truth where
it is a measurement. The tests share one JupyterLab and one data root, in the notebooks'
order: 05 validates the bundle 00 published. The scan, Macbeth and snapshot notebooks are
run here only (each takes minutes); ``tests/notebooks`` runs the others without a person.
"""

from __future__ import annotations

import json

import nbformat
import numpy as np
import pytest
import yaml

from sassi_bench.bundle import load, verify
from sassi_bench.calibrate.guide_registration import field_discrepancy_px
from sassi_bench.rig import open_rig
from sassi_bench.rig.sim import truth


def _published(lab) -> list[str]:
    folder = lab.data / "sim"
    return sorted(p.name for p in folder.glob("v*")) if folder.is_dir() else []


def test_00_reject_then_accept_publishes_once_and_reopens_with_its_results(lab, open_notebook):
    book = open_notebook("00_quickstart.ipynb")
    try:
        book.run_all([1, 2])
        frames = book.run(4)
        assert "\u26a0 spectral all open:" in frames and "Shorten the exposure" in frames
        # (cell 5, the live view, is run unattended by tests/notebooks/test_notebooks.py)

        book.run(7)  # the calibration, then the accept/reject choice (accept: it passed)
        choice = book.cell(7).locator(".widget-toggle-buttons")
        assert book.kernel_value("decision.children[-1].value") == "accept"
        choice.get_by_role("button", name="reject").click()
        # the click reaches the kernel on the page's connection, a moment later
        assert book.kernel_until("decision.children[-1].value", "reject") == "reject"
        assert "not published: the fit was rejected" in book.run(8)
        assert book.kernel_value("bundle is None") is True and _published(lab) == []

        choice.get_by_role("button", name="accept").click()
        said = book.run(8)
        assert "published sim/v0001" in said and "latest: sim/v0001" in said
        assert book.kernel_value("bundle.version") == "v0001" and _published(lab) == ["v0001"]
        verify(lab.data / "sim" / "v0001")
        again = book.run(8)  # run again: the same fit is not published twice
        assert again.startswith("not published again: sim/v0001") and _published(lab) == ["v0001"]
        assert "wavelength bins" in book.run(10)
        book.save(showing="not published again: sim/v0001")
    finally:
        book.close()

    saved = nbformat.read(lab.root / "00_quickstart.ipynb", as_version=4)
    texts = ["".join(o.get("text", "") for o in c.get("outputs", [])) for c in saved.cells]
    assert texts[8].startswith("not published again: sim/v0001")
    states = saved.metadata["widgets"]["application/vnd.jupyter.widget-state+json"]["state"]
    (choice_state,) = [
        model["state"]
        for model in states.values()
        if model["state"].get("_options_labels") == ["accept", "reject"]
    ]
    assert choice_state["index"] == 0  # "accept", the choice saved with the notebook

    # A fresh kernel: the reopened notebook shows what ran and what was chosen.
    for session in lab.api("sessions"):
        if session["path"].endswith("00_quickstart.ipynb"):
            _delete(lab, f"sessions/{session['id']}")
    reopened = open_notebook("00_quickstart.ipynb")
    assert "not published again: sim/v0001" in reopened.output(8)
    assert "wavelength bins" in reopened.output(10)
    shown = reopened.cell(7).locator(".widget-toggle-button.mod-active")
    assert shown.inner_text().strip() == "accept"


def _delete(lab, path: str) -> None:
    import urllib.request

    request = urllib.request.Request(
        f"{lab.url}/api/{path}", method="DELETE", headers={"Authorization": f"token {lab.token}"}
    )
    urllib.request.urlopen(request, timeout=30).close()


#: The session notebooks 01 and 02 share here: one of their own, as 00 has captured
#: its default session with every laser (a session captured with other choices is refused).
SWEEP_SESSION = "browser-sweeps"
PLANNED_LASERS = "sorted({float(s.tags['laser']) for s in sweeps.sweep.plan.steps})"
CAPTURED_LASERS = (
    "sorted({float(sweeps.sweep.plan.steps[i].tags['laser']) for i in sweeps.sweep.completed})"
)


def _saved_procedure(lab) -> dict:
    path = lab.data / "procedures" / f"{SWEEP_SESSION}-spectral_calibration.yaml"
    return yaml.safe_load(path.read_text("utf-8"))


def test_01_an_unticked_laser_is_neither_planned_nor_captured_nor_kept(lab, open_notebook):
    book = open_notebook("01_laser_sweeps.ipynb")
    try:
        book.type_into(1, f'\nsession_id = "{SWEEP_SESSION}"\nprogress = False')
        book.run_all([1, 2])
        every = book.kernel_value("tuple(float(nm) for nm in rig.description.lasers_nm)")
        assert 532.0 in every and book.kernel_value("lasers.value") == every
        book.cell(2).get_by_role("checkbox", name="532 nm").click()
        kept = tuple(nm for nm in every if nm != 532.0)
        book.kernel_until("lasers.value", kept)

        book.run_all([4, 6])  # the exposure target as it is, then the capture
        assert book.kernel_value("procedure['lasers_nm']") == list(kept)
        assert book.kernel_value(PLANNED_LASERS) == list(kept)
        assert book.kernel_value(CAPTURED_LASERS) == list(kept)
        assert book.kernel_value("len(sweeps.sweep.missing)") == 0
        assert _saved_procedure(lab)["lasers_nm"] == list(kept)  # what 02 and 06 read
    finally:
        book.close()


#: An SLM rectangle (rows 150-250, columns 250-350) inside the field every laser lights.
REGION = {"rows": "150-250", "columns": "250-350"}
EXCLUDED = [[150, 250, 250, 350]]  # [row0, col0, row1, col1], as the procedure lists it
POINTS_INSIDE = (
    "sum(int(((d.slm_v >= 150) & (d.slm_v < 250) & (d.slm_u >= 250) & (d.slm_u < 350)).sum())"
    " for d in result.lasers)"
)


def test_02_an_excluded_region_set_by_the_widgets_is_left_out_of_the_fit(lab, open_notebook):
    if not (lab.data / "procedures" / f"{SWEEP_SESSION}-spectral_calibration.yaml").is_file():
        pytest.skip("needs the sweeps the notebook 01 test captures")
    book = open_notebook("02_dispersion_and_blur.ipynb")
    try:
        book.type_into(1, f'\nsession_id = "{SWEEP_SESSION}"\nprogress = False')
        book.run_all([1, 2])  # the residual maps, dispersion and blur plots are not needed
        inside = book.kernel_value(POINTS_INSIDE)
        assert inside > 1000, "the region should hold decoded points before it is excluded"
        total = book.kernel_value("sum(d.camera_x.size for d in result.lasers)")

        book.run(7)
        picker = book.cell(7)
        picker.get_by_role("checkbox", name="exclude a region").click()
        for name, text in REGION.items():
            slider = picker.locator(".widget-slider").filter(
                has=book.page.locator(".widget-label", has_text=name)
            )
            book.type_readout(slider.locator(".widget-readout"), text)
        book.kernel_until("excluded_region(region)", EXCLUDED)

        book.run(8)  # the fit again, without the region
        assert book.kernel_value("procedure['fit']['exclude_regions_slm_px']") == EXCLUDED
        assert book.kernel_value(POINTS_INSIDE) == 0
        assert book.kernel_value("sum(d.camera_x.size for d in result.lasers)") == total - inside
        assert book.kernel_value("decision.children[-1].value") == "accept"
        assert book.run(11).startswith("kept: 06_publish_bundle publishes this fit")
        assert _saved_procedure(lab)["fit"]["exclude_regions_slm_px"] == EXCLUDED
    finally:
        book.close()


def _de00(lab, run: str) -> list[float]:
    doc = json.loads((lab.data / "reports" / "macbeth" / run / "macbeth_report.json").read_text())
    return [patch["de00"] for patch in doc["patches"]]


def test_05_a_moved_chart_corner_changes_the_localisation_and_the_scores(lab, open_notebook):
    if _published(lab) == []:
        pytest.skip("needs the bundle the quick-start test publishes")
    book = open_notebook("05_macbeth_validation.ipynb")
    try:
        book.type_into(1, '\nwhite_reference = "patch"')  # the chart's white: one scan less
        book.run_all([1, 2, 3, 4, 5])
        assert book.images(5) >= 1  # the patch grid on the chart
        assert book.kernel_value("procedure['white_reference']['source']") == "patch"
        first = book.run(6)
        assert "run-001 (new)" in first and "PASS mean_de00" in first
        scores = book.kernel_value("[c.value for c in result.checks]")

        start = book.kernel_value("float(chart_corners(corners)[0, 0])")
        moved = round(start + 12.0, 1)  # what is typed, and so what the slider holds
        slider = book.cell(4).locator(".widget-slider").first  # u 1, v 1, u 6, ... u 19, v 19
        assert slider.locator(".widget-label").inner_text().strip() == "u 1"
        book.type_readout(slider.locator(".widget-readout"), f"{moved:g}")
        book.kernel_until("float(chart_corners(corners)[0, 0])", moved)

        book.run(5)
        second = book.run(6)
        assert "run-002 (the earlier report run-001 is kept)" in second
        assert book.kernel_value("[c.value for c in result.checks]") != scores
        assert _de00(lab, "run-002") != _de00(lab, "run-001")
    finally:
        book.close()


def _versions(lab) -> set[str]:
    return set(_published(lab))


#: A scan setting a person types: rows 4 SLM px apart (400 frames, not 500).
SCAN_PITCH = (100, 4)


def test_03_a_typed_scan_pitch_is_scanned_and_its_cube_written_under_the_data_root(
    lab, open_notebook
):
    if _published(lab) == []:
        pytest.skip("needs the bundle the quick-start test publishes")
    import xarray as xr

    before = _versions(lab)
    book = open_notebook("03_pinhole_scan.ipynb")
    try:
        book.type_into(1, f"\nscan_pitch = {SCAN_PITCH}\nresponse_every = 50\nprogress = False")
        book.run_all([1, 2])
        said = book.run(4)  # the radiometric response: a new bundle version
        version = book.kernel_value("bundle.version")
        assert f"published sim/{version} with the radiometric response" in said
        assert _versions(lab) == before | {version} and book.kernel_value(
            "bundle.response is not None"
        )

        book.run(5)  # the scan
        assert book.kernel_value("tuple(run.session.plan.parameters['pitch'])") == SCAN_PITCH
        pinholes = book.kernel_value("len(run.session.plan.select(role='pinholes'))")
        assert pinholes == SCAN_PITCH[0] * SCAN_PITCH[1]
        assert book.kernel_value("len(run.session.completed) == len(run.session.plan.steps)")
        book.run(6)
        assert book.images(6) >= 1  # spectra at three pixels
        said = book.run(7)
        cube_path = lab.data / "cubes" / f"lab-spectral-colorchecker-sim-{version}.nc"
        assert f"cube: wrote {cube_path}" in said
        sha = book.kernel_value("run.session.sha256()")
        # Run again, the response cell keeps the bundle and the cube cell the cube.
        assert f"kept: sim/{version} already has a radiometric" in book.run(4)
        assert f"cube: kept {cube_path}" in book.run(7)
        assert _versions(lab) == before | {version}
    finally:
        book.close()

    with xr.open_dataset(cube_path) as cube:
        assert cube.attrs["bundle_version"] == version and cube.attrs["session_sha256"] == sha
        assert cube.attrs["session_id"] == "lab-spectral-scan-colorchecker"
        assert cube["radiance"].shape[:2] == (400, 640)  # the sim SLM
        assert np.isfinite(cube["radiance"].values).mean() > 0.9


def _with_guide(lab) -> list[str]:
    return [v for v in _published(lab) if load(lab.data / "sim" / v).guide_to_slm is not None]


def test_04_a_rejected_homography_is_not_published_and_an_accepted_one_is(lab, open_notebook):
    if _published(lab) == []:
        pytest.skip("needs the bundle the quick-start test publishes")
    before = _versions(lab)
    book = open_notebook("04_guide_homography.ipynb")
    try:
        book.type_into(1, "\nprogress = False")
        book.run_all([1, 2, 6])  # the registration, then the choice (the figures are not run)
        choice = book.cell(6).locator(".widget-toggle-buttons")
        assert book.kernel_value("decision.children[-1].value") == "accept"
        choice.get_by_role("button", name="reject").click()
        book.kernel_until("decision.children[-1].value", "reject")
        assert "not published: the registration was rejected" in book.run(7)
        assert _versions(lab) == before

        choice.get_by_role("button", name="accept").click()
        book.kernel_until("decision.children[-1].value", "accept")
        said = book.run(7)
        version = book.kernel_value("path.name")
        assert f"published sim/{version} (dispersion, blur, guide homography" in said
        assert f"latest: sim/{version} (dispersion, blur, guide homography" in said
        assert _versions(lab) == before | {version}
        homography = book.kernel_value("result.homography.tolist()")
    finally:
        book.close()
    verify(lab.data / "sim" / version)
    published = load(lab.data / "sim" / version)
    np.testing.assert_allclose(published.guide_to_slm, homography)
    bench = truth(open_rig("sim"))
    error_px, _ = field_discrepancy_px(published.guide_to_slm, bench.guide_to_slm, (400, 640))
    assert error_px < 0.3  # RMS over the SLM against the bench's homography


def test_06_a_rejected_fit_is_not_published_and_an_accepted_one_becomes_latest(lab, open_notebook):
    if not (lab.data / "procedures" / f"{SWEEP_SESSION}-spectral_calibration.yaml").is_file():
        pytest.skip("needs the sweeps the notebook 01 test captures")
    before = _versions(lab)
    book = open_notebook("06_publish_bundle.ipynb")
    try:
        book.type_into(1, f'\nsession_id = "{SWEEP_SESSION}"\nprogress = False')
        book.run_all([1, 2])  # 01's sweeps (all captured) fitted as 02 settled them
        assert book.kernel_value("procedure['fit']['exclude_regions_slm_px']") == EXCLUDED
        choice = book.cell(2).locator(".widget-toggle-buttons")
        assert book.kernel_value("decision.children[-1].value") == "accept"
        choice.get_by_role("button", name="reject").click()
        book.kernel_until("decision.children[-1].value", "reject")
        assert "not published: the fit was rejected" in book.run(3)
        assert book.kernel_value("path is None") and _versions(lab) == before

        choice.get_by_role("button", name="accept").click()
        book.kernel_until("decision.children[-1].value", "accept")
        said = book.run(3)
        version = book.kernel_value("path.name")
        # 01 unticked a laser and 02 excluded a region: not the fit 00 published.
        assert f"published sim/{version} (dispersion, blur;" in said
        assert f"latest: sim/{version} (dispersion, blur;" in said
    finally:
        book.close()
    assert _versions(lab) == before | {version}
    assert (lab.data / "sim" / "LATEST").read_text().strip() == version
    verify(lab.data / "sim" / version)
    assert load(lab.data / "sim" / version).wavelengths.size > 30


def test_07_a_snapshot_taken_on_the_homography_bundle_is_scored_and_reported(lab, open_notebook):
    with_guide = _with_guide(lab)
    if not with_guide:
        pytest.skip("needs the bundle with a guide homography the notebook 04 test publishes")
    book = open_notebook("07_snapshot.ipynb")
    try:
        # One adaptive snapshot and the comparison masks: no photon-starved one, no video.
        book.type_into(1, "\nlow_light = False\nvideo_frames = 0\nprogress = False")
        book.run_all([1, 2])
        assert book.kernel_value("bundle.version") == with_guide[-1]
        book.run(4)  # the scan of the scene, then the snapshots
        runs = book.kernel_value("sorted(result.runs)")
        assert "adaptive" in runs and "adaptive_low_light" not in runs
        for figure in (6, 8, 9, 11):  # masks, reconstruction, per-band PSNR, spectra
            book.run(figure)
            assert book.images(figure) >= 1, f"cell {figure} shows no figure"
        said = book.run(13)
        folder = lab.data / "reports" / "snapshot" / "run-001"
        assert book.kernel_value("str(html_path)") == str(folder / "snapshot_report.html")
        psnr = book.kernel_value("result.runs['adaptive'].scores['rank1'].psnr_affine_db")
        assert "PASS " in said or "FAIL " in said
    finally:
        book.close()
    doc = json.loads((folder / "snapshot_report.json").read_text())
    assert doc["snapshots"]["adaptive"]["scores"]["rank1"]["psnr_affine_db"] == pytest.approx(psnr)
    assert psnr > 25.0


def test_08_a_typed_bundle_version_is_health_checked_and_its_verdict_kept(lab, open_notebook):
    if _published(lab) == []:
        pytest.skip("needs the bundle the quick-start test publishes")
    from sassi_bench.storage.health_history import HealthHistory, history_path

    book = open_notebook("08_health_check.ipynb")
    try:
        book.type_into(1, '\nbundle_version = "v0001"\nprogress = False')
        book.run(1)
        said = book.run(2)  # the two frames and the verdict (the figure cells are not run)
        assert book.kernel_value("check.bundle_version") == "v0001"
        verdict = book.kernel_value("check.verdict")
        assert f"verdict: {verdict}" in said and "health check of sim bundle v0001" in said
    finally:
        book.close()
    (row,) = HealthHistory(history_path(lab.data)).rows(rig="sim")
    # The sim bench holds still: v0001 (the quick start's fit) holds.
    assert row["bundle_version"] == "v0001" and row["verdict"] == verdict == "holds"
