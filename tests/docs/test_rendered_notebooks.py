"""The site shows every guided notebook with the outputs of a real run on the virtual bench:
``benchmarks/render_notebooks.py`` keeps the executed copies in ``docs/_data/notebooks/``
with where they come from, and ``docs/conf.py`` uses a copy only while it ran the
notebook's present code."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import pytest

pytest.importorskip("sphinx", reason="Sphinx is not installed: pip install -e '.[docs]'")

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = ROOT / "notebooks"
RENDERED = ROOT / "docs" / "_data" / "notebooks"
RERUN = "run `python benchmarks/render_notebooks.py` after changing a notebook's code"


@pytest.fixture(scope="module")
def conf():
    """``docs/conf.py`` as a module (importing it builds nothing)."""
    spec = importlib.util.spec_from_file_location("docs_conf", ROOT / "docs" / "conf.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _outputs(text: str) -> list[dict]:
    return [
        output
        for cell in json.loads(text)["cells"]
        if cell["cell_type"] == "code"
        for output in cell["outputs"]
    ]


def test_every_notebook_has_an_executed_copy_of_its_present_code(conf):
    stale = []
    for notebook in sorted(NOTEBOOKS.glob("*.ipynb")):
        text, rendered = conf.with_outputs(notebook)
        if not rendered:
            stale.append(notebook.name)
            continue
        outputs = _outputs(text)
        assert any(o["output_type"] == "stream" for o in outputs), notebook.name
        assert not any(o["output_type"] == "error" for o in outputs), notebook.name
    assert not stale, f"{stale}: {RERUN}"


def test_the_executed_copies_say_where_they_come_from():
    record = json.loads((RENDERED / "provenance.json").read_text())
    assert record["rig"] == "sim"
    assert record["command"].startswith("python benchmarks/render_notebooks.py")
    assert record["date"] and record["machine"]
    assert sorted(record["notebooks"]) == sorted(p.name for p in NOTEBOOKS.glob("*.ipynb"))
    for name, run in record["notebooks"].items():
        assert run["settings"]["data"] == "'calib_data'", name


def test_the_executed_copies_are_static_and_neutral():
    for path in sorted(RENDERED.glob("*.ipynb")):
        text = path.read_text()
        book = json.loads(text)
        # No widget state (it needs a kernel or a CDN); widgets show as static HTML.
        assert "widgets" not in book["metadata"], path.name
        assert "application/vnd.jupyter.widget-view+json" not in text, path.name
        # The temporary data root does not show: paths read calib_data/...
        assert "/tmp/" not in text, path.name
        # Progress bars as their last state, not every update.
        assert "\\r" not in text, path.name
    # A modest size in the repository.
    assert sum(p.stat().st_size for p in RENDERED.iterdir()) < 6e6


def test_a_notebook_whose_code_changed_is_shown_without_outputs(conf, tmp_path):
    name = "08_health_check.ipynb"
    book = json.loads((NOTEBOOKS / name).read_text())
    code = next(c for c in book["cells"] if c["cell_type"] == "code" and c["source"])
    code["source"] = "".join(code["source"]) + "\n# edited"
    edited = tmp_path / name
    edited.write_text(json.dumps(book))
    text, rendered = conf.with_outputs(edited, RENDERED)
    assert not rendered and not _outputs(text)
    # A text-only edit keeps the outputs, and the page shows the edited text.
    book = json.loads((NOTEBOOKS / name).read_text())
    prose = next(c for c in book["cells"] if c["cell_type"] == "markdown")
    prose["source"] = "".join(prose["source"]) + "\n\nAn added sentence."
    edited.write_text(json.dumps(book))
    text, rendered = conf.with_outputs(edited, RENDERED)
    assert rendered and _outputs(text) and "An added sentence." in text
