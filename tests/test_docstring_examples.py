"""Docstring examples either run (pytest's --doctest-modules, with the root conftest.py's
namespace) or are shown as literal blocks marked not run: none is skipped."""

from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "sassi_bench"


def test_no_docstring_example_is_skipped():
    skipped = [
        f"{path.relative_to(PACKAGE.parent)}:{number}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if "sassi_upstream" not in path.parts
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if "doctest: +SKIP" in line
    ]
    assert not skipped, "make these examples run or show them as literal blocks: " + ", ".join(
        skipped
    )
