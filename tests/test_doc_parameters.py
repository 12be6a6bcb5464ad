"""The procedure pages' parameter tables come from one source: the shipped procedure YAMLs.

Every procedure page has a Parameters section whose tables equal what
``benchmarks/procedure_parameters.py`` renders from ``procedures/<kind>.yaml``, and every
key of every shipped procedure says what it means in its comment.
"""

from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

import pytest
import yaml

from sassi_bench.procedure import load_procedure

ROOT = Path(__file__).parents[1]


def _module():
    path = ROOT / "benchmarks" / "procedure_parameters.py"
    spec = importlib.util.spec_from_file_location("procedure_parameters", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


tables = _module()
SHIPPED = sorted(tables.PROCEDURES.glob("*.yaml"))
PAGES = sorted(p for p in tables.PAGES.glob("*.md") if p.name != "index.md")


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_the_comments_are_read_key_by_key(path):
    """The comment reader finds the keys ``yaml`` loads, in order, with their values."""
    found = tables.parameters(path)
    loaded = tables.loaded_keys(path)
    assert [p.key for p in found] == list(loaded)
    for p in found:
        if not p.section:
            assert yaml.safe_load(p.value) == loaded[p.key], p.key
    load_procedure(path.stem, path)  # the shipped file is a valid procedure


@pytest.mark.parametrize("path", SHIPPED, ids=lambda p: p.stem)
def test_every_key_says_what_it_means(path):
    keys = [p for p in tables.parameters(path) if not p.section and p.key != "name"]
    unexplained = [p.key for p in keys if not p.meaning]
    assert not unexplained, f"procedures/{path.name}: give {unexplained} a comment"


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.stem)
def test_every_procedure_page_has_its_parameters(page):
    text = page.read_text()
    assert re.search(r"^## Parameters$", text, re.MULTILINE), page.name
    found = tables.blocks(text)
    assert found, f"{page.name}: no <!-- parameters: KIND --> table"
    for kind, held, rendered in found:
        assert held == rendered, (
            f"docs/procedures/{page.name}: the {kind} table differs from procedures/{kind}.yaml;"
            " run `python benchmarks/procedure_parameters.py`"
        )


def test_the_pages_cover_every_shipped_procedure():
    shown = {kind for page in PAGES for kind, _, _ in tables.blocks(page.read_text())}
    assert shown == {p.stem for p in SHIPPED}


def test_a_changed_value_or_comment_is_caught(tmp_path):
    """The check above can fail: a table from an edited YAML differs, and rewriting the page
    restores it."""
    for path in SHIPPED:
        (tmp_path / path.name).write_text(path.read_text())
    edited = tmp_path / "health_check.yaml"
    edited.write_text(
        edited.read_text()
        .replace("frames: 1  ", "frames: 2  ", 1)
        .replace("(1: offset and tilt)", "(1: offset only)", 1)
    )
    page = (tables.PAGES / "health_check.md").read_text()
    (_, held, rendered) = tables.blocks(page, tmp_path)[0]
    assert held != rendered
    assert "| `frames` | `2` |" in rendered and "(1: offset only)" in rendered
    assert tables.render(tables.render(page, tmp_path)) == page
    # A null is shown as derived, or as none where it turns a check off.
    full = tables.table("full_calibration")
    assert "| `response.pitch_px` | derived |" in full
    assert "| `response.sigma_max` | none |" in full
    # A section's own comment heads its keys; a key's continued comment is one cell.
    assert "| `response` |  | radiometric response" in full
    assert "about a third of the bytes); records (no frames)." in full
    # Markdown in a comment is escaped, not rendered (lamp:<name> is no HTML tag).
    assert r"lamp:\<name\>" in tables.table("health_check")


def test_a_line_the_reader_cannot_read_is_refused(tmp_path):
    path = tmp_path / "odd.yaml"
    path.write_text("name: odd\nlist:\n  - 1\n")
    with pytest.raises(ValueError, match=r"odd\.yaml:3"):
        tables.parameters(path)
