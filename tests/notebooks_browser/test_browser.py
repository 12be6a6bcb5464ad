"""The guided notebooks clicked through in JupyterLab by a headless Chromium.

Each test runs a notebook cell by cell from the keyboard, changes its widgets by clicking
and typing, and checks the effect on what the kernel holds and on what is published or
written under the data root (not on pixels). The tests share one JupyterLab and one data
root, in the notebooks' order: 05 validates the bundle 00 published.
"""

from __future__ import annotations

import json

import nbformat
import pytest

from sassi_bench.bundle import verify


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
        assert book.kernel_value("decision.children[-1].value") == "reject"
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
        assert book.kernel_value("procedure['white_reference']['source']") == "patch"
        first = book.run(6)
        assert "run-001 (new)" in first and "PASS mean_de00" in first
        scores = book.kernel_value("[c.value for c in result.checks]")

        start = book.kernel_value("float(chart_corners(corners)[0, 0])")
        moved = round(start + 12.0, 1)  # what is typed, and so what the slider holds
        slider = book.cell(4).locator(".widget-slider").first  # u 1, v 1, u 6, ... u 19, v 19
        assert slider.locator(".widget-label").inner_text().strip() == "u 1"
        readout = slider.locator(".widget-readout")
        readout.click()
        book.page.keyboard.press("Control+a")
        book.page.keyboard.type(f"{moved:g}")
        book.page.keyboard.press("Enter")
        assert book.kernel_value("float(chart_corners(corners)[0, 0])") == moved

        book.run(5)
        second = book.run(6)
        assert "run-002 (the earlier report run-001 is kept)" in second
        assert book.kernel_value("[c.value for c in result.checks]") != scores
        assert _de00(lab, "run-002") != _de00(lab, "run-001")
    finally:
        book.close()
