"""The Python examples of the README and the user pages run as written (they are
doctests), on a real bundle."""

from __future__ import annotations

import dataclasses
import doctest
import re
from pathlib import Path

import pytest

from sassi_bench.bundle import load, publish
from sassi_bench.rig.sim import truth

ROOT = Path(__file__).parents[1]
#: The README and the user pages (the dated notes are history, not examples to run).
PAGES = [
    ROOT / "README.md",
    *sorted(
        p for p in (ROOT / "docs").rglob("*.md") if p.relative_to(ROOT / "docs").parts[0] != "notes"
    ),
]


def python_blocks() -> list[tuple[Path, str]]:
    """The ```python blocks of the README and the user pages, with their page."""
    return [
        (page, block)
        for page in PAGES
        for block in re.findall(r"```python\n(.*?)```", page.read_text(), flags=re.DOTALL)
    ]


@pytest.fixture(scope="module")
def data_with_a_sim_bundle(calibrated_sim, tmp_path_factory):
    """A data root whose latest sim bundle is the suite's spectral calibration of the sim
    rig with its guide -> SLM homography (the truth's: the registration is tested
    elsewhere), as ``sassi-bench calibrate`` would publish it."""
    rig, result, _ = calibrated_sim
    root = tmp_path_factory.mktemp("readme")
    bundle = load(result.bundle_path)
    models = dataclasses.replace(bundle.models, guide_to_slm=truth(rig).guide_to_slm)
    publish(
        models,
        rig=rig.description,
        quality={"checks": list(result.checks), "residuals": {}},
        procedure=dict(bundle.manifest["procedure"]),
        data=root,
    )
    return root


def test_every_python_block_of_the_pages_is_a_doctest():
    blocks = python_blocks()
    assert {page.name for page, _ in blocks} >= {"getting_started.md", "bundle_api.md"}
    for page, block in blocks:
        lines = [line for line in block.splitlines() if line.strip()]
        assert lines[0].startswith(">>> "), (page, block)


@pytest.mark.parametrize("index", range(len(python_blocks())))
def test_page_examples_run(index, data_with_a_sim_bundle, monkeypatch):
    monkeypatch.setenv("SASSI_BENCH_DATA", str(data_with_a_sim_bundle))
    page, block = python_blocks()[index]
    name = f"{page.relative_to(ROOT)} block {index}"
    test = doctest.DocTestParser().get_doctest(block, {}, name, str(page), 0)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    failures = []
    runner.run(test, out=failures.append)
    assert runner.failures == 0, "".join(failures)
    assert runner.tries == len(test.examples) > 0
