"""The guided notebooks publish and keep only what a person accepted, after they saw it.

Read without running them (fast): every call that publishes a bundle or keeps a fitted
procedure sits under ``if accepted(decision)``, in a cell after the one that shows the
accept/reject choice, and no calibration publishes on its own before that choice.
"""

from __future__ import annotations

import ast
from pathlib import Path

import nbformat
import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[2] / "notebooks").glob("*.ipynb"))

#: Calls that publish a bundle or keep a fit for publishing later.
KEEPERS = {
    "publish_spectral",
    "publish_guide",
    "publish",
    "publish_derived",
    "publish_once",
    "publish_spectral_once",
    "publish_guide_once",
}
#: Calls that publish unless told not to.
PUBLISH_BY_DEFAULT = {"run_spectral_calibration", "run_guide_registration"}


def _name(call: ast.Call) -> str:
    func = call.func
    return func.id if isinstance(func, ast.Name) else getattr(func, "attr", "")


def _guarded(node: ast.AST, parents: dict[ast.AST, ast.AST]) -> bool:
    while node in parents:
        node = parents[node]
        if isinstance(node, ast.If) and "accepted(decision)" in ast.unparse(node.test):
            return True
    return False


def _cells(path: Path) -> list[ast.Module]:
    book = nbformat.read(path, as_version=4)
    return [ast.parse(c.source) for c in book.cells if c.cell_type == "code"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_only_an_accepted_fit_is_published_or_kept(path):
    cells = _cells(path)
    decided = [
        i for i, tree in enumerate(cells)
        if any(isinstance(n, ast.Call) and _name(n) == "accept_checks" for n in ast.walk(tree))
    ]  # fmt: skip
    for i, tree in enumerate(cells):
        parents = {
            child: parent for parent in ast.walk(tree) for child in ast.iter_child_nodes(parent)
        }
        for call in (n for n in ast.walk(tree) if isinstance(n, ast.Call)):
            name = _name(call)
            keeps = name in KEEPERS or (name == "save_working_procedure" and decided)
            if name in PUBLISH_BY_DEFAULT:
                quiet = {k.arg: ast.unparse(k.value) for k in call.keywords}
                assert quiet.get("publish_bundle") == "False", (
                    f"{path.name}: {name} publishes before anyone could reject the fit"
                )
            if keeps:
                assert decided and i > decided[0], f"{path.name}: {name} before the decision"
                assert _guarded(call, parents), f"{path.name}: {name} not under accepted(decision)"
