"""The package's layers, as ``docs/ARCHITECTURE.md`` tables them, hold in the code.

Every module file is parsed (not imported), so imports inside functions, under
``TYPE_CHECKING``, relative imports and ``importlib.import_module("...")`` /
``__import__("...")`` with a constant name all count. A module may import its own package
and the packages its row lists; a package's face (``__init__``) may also import its own
subpackages. The table itself must list only lower rows, so an import can never go up,
and no modules may import each other in a circle.

This replaces one-off guards: the virtual bench (``rig.sim``) is listed for no package,
so nothing but the ``rig`` face's ``open_rig`` reaches it or its ground truth, and the
snapshot package (the reference bundle consumer) may import ``bundle`` and ``spectra``
only. The bench-only sections of a rig description have their own guard
(``tests/test_no_truth_in_procedures.py``).
"""

from __future__ import annotations

import ast
import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

import sassi_bench

PACKAGE = Path(sassi_bench.__file__).parent
ARCHITECTURE = PACKAGE.parent / "docs" / "ARCHITECTURE.md"
ROOT = "sassi_bench"


# --- the table ---------------------------------------------------------------------------


def layer_table(text: str) -> dict[str, tuple[str, ...]]:
    """``{package: packages it may import}`` from the rows of the "Layers" table, bottom
    layer first (dotted names relative to ``sassi_bench``)."""
    section = text.split("\n## Layers", 1)[1].split("\n## ", 1)[0]
    table: dict[str, tuple[str, ...]] = {}
    for line in section.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) < 3 or not cells[0].startswith("`"):
            continue
        packages = re.findall(r"`([\w.]+)`", cells[0])
        allowed = tuple(re.findall(r"`([\w.]+)`", cells[-1]))
        for package in packages:
            table[package] = allowed
    return table


TABLE = layer_table(ARCHITECTURE.read_text(encoding="utf-8"))


def row_of(module: str) -> str | None:
    """The table row a module belongs to: the longest listed package it is inside."""
    name = module.removeprefix(ROOT + ".") if module != ROOT else ""
    inside = [p for p in TABLE if name == p or name.startswith(p + ".")]
    return max(inside, key=len, default=None)


# --- the code's imports ------------------------------------------------------------------


def module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_names(source: str, module: str, is_package: bool = False) -> set[str]:
    """Every ``sassi_bench`` name ``source`` (the code of ``module``) imports, anywhere in
    it, resolved to absolute dotted names (``from a import b`` gives ``a.b``: the module
    ``a.b`` if there is one, else the name ``b`` of module ``a``)."""
    package = module if is_package else module.rsplit(".", 1)[0]
    names: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            names.update(f"{base}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Call) and node.args:
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            first = node.args[0]
            if called in ("import_module", "__import__") and isinstance(first, ast.Constant):
                names.add(str(first.value))
    return {n for n in names if n == ROOT or n.startswith(ROOT + ".")}


def package_files() -> list[Path]:
    """The package's modules (the SASSI authors' vendored files are data the export
    compiles functions from, not modules of the package)."""
    skip = {"procedures", "sassi_upstream"}
    return sorted(p for p in PACKAGE.rglob("*.py") if not skip.intersection(p.parts))


MODULES = {module_name(p): p for p in package_files()}


def imported_modules(module: str) -> set[str]:
    """The package's modules that ``module`` imports: a name imported from a module is that
    module; a submodule imported from a package is the submodule (its package's face is
    then only being initialised, not used)."""
    path = MODULES[module]
    found = set()
    for name in imported_names(path.read_text(), module, path.name == "__init__.py"):
        while name not in MODULES and "." in name:
            name = name.rsplit(".", 1)[0]
        if name in MODULES and name != module:
            found.add(name)
    return found


GRAPH = {module: imported_modules(module) for module in MODULES}


def violation(importer: str, imported: str) -> str | None:
    """Why ``importer`` may not import ``imported``, or None."""
    if importer in (ROOT, f"{ROOT}.__main__") or (
        MODULES[importer].name == "__init__.py" and imported.startswith(importer + ".")
    ):
        return None  # a package's face re-exports its own subpackages
    mine, theirs = row_of(importer), row_of(imported)
    if theirs is None:
        return f"{imported} is in no row of the layer table"
    if mine == theirs or theirs in TABLE[mine]:
        return None
    return f"{mine} may import {', '.join(TABLE[mine]) or 'nothing'}, not {theirs}"


# --- the tests ---------------------------------------------------------------------------


def test_the_table_lists_every_package_once_and_only_lower_rows():
    rows = list(TABLE)
    for i, package in enumerate(rows):
        for allowed in TABLE[package]:
            assert allowed in rows[:i], f"{package} may import {allowed}, which is not below it"
    top_level = {p.name for p in PACKAGE.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    top_level |= {p.stem for p in PACKAGE.glob("*.py") if p.stem not in ("__init__", "__main__")}
    missing = sorted(top_level - {r.split(".")[0] for r in rows} - {"procedures"})
    assert not missing, f"packages missing from the layer table in {ARCHITECTURE.name}: {missing}"


@pytest.mark.parametrize("module", sorted(MODULES), ids=str)
def test_imports_follow_the_layer_table(module):
    assert row_of(module) is not None or module in (ROOT, f"{ROOT}.__main__"), (
        f"{module} is in no row of the layer table"
    )
    bad = [f"{name}: {why}" for name in sorted(GRAPH[module]) if (why := violation(module, name))]
    assert not bad, f"{module} imports against the layer table:\n  " + "\n  ".join(bad)


def strongly_connected(graph: dict[str, set[str]]) -> Iterator[list[str]]:
    """Tarjan's strongly connected components with more than one module."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()

    def visit(node: str) -> Iterator[list[str]]:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in graph.get(node, ()):
            if other not in index:
                yield from visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            component = []
            while True:
                top = stack.pop()
                on_stack.discard(top)
                component.append(top)
                if top == node:
                    break
            if len(component) > 1:
                yield sorted(component)

    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(graph)))
    for node in sorted(graph):
        if node not in index:
            yield from visit(node)


def test_no_modules_import_each_other_in_a_circle():
    circles = list(strongly_connected(GRAPH))
    assert not circles, "import circles:\n  " + "\n  ".join(" <-> ".join(c) for c in circles)


def below(package: str) -> set[str]:
    """``package`` and every row it may import, directly or through the rows it imports."""
    found, todo = set(), [package]
    while todo:
        row = todo.pop()
        if row not in found:
            found.add(row)
            todo.extend(TABLE[row])
    return found


LOADER = """
import importlib, json, sys
import sassi_bench
loaded = {}
for package in json.loads(sys.argv[1]):
    before = set(sys.modules)
    for name in json.loads(sys.argv[2])[package]:
        importlib.import_module(name)
    loaded[package] = sorted(m for m in set(sys.modules) - before if m.startswith("sassi_bench."))
print(json.dumps(loaded))
"""


@pytest.fixture(scope="module")
def loaded_by_package() -> dict[str, list[str]]:
    """What importing every module of each top-level package loads, in one interpreter, the
    packages imported from the bottom row up (so a package's new modules are its own or
    above it)."""
    packages = [p for p in TABLE if "." not in p]
    own = {
        p: sorted(m for m in MODULES if m == f"{ROOT}.{p}" or m.startswith(f"{ROOT}.{p}."))
        for p in packages
    }
    out = subprocess.run(
        [sys.executable, "-c", LOADER, json.dumps(packages), json.dumps(own)],
        capture_output=True, text=True, check=True,
    ).stdout  # fmt: skip
    return json.loads(out)


@pytest.mark.parametrize("package", [p for p in TABLE if "." not in p], ids=str)
def test_importing_a_package_loads_only_what_its_row_allows(package, loaded_by_package):
    """At run time too: importing a package's modules loads no module of a package below
    which it does not stand (the virtual bench, fitting code, procedures...)."""
    allowed = below(package)
    stray = [
        m for m in loaded_by_package[package]
        if row_of(m) not in allowed and not m.startswith(f"{ROOT}.{package}.")
    ]  # fmt: skip
    assert not stray, f"importing {ROOT}.{package} loads {stray}"


# --- the parser sees every kind of import ------------------------------------------------


@pytest.mark.parametrize(
    ("code", "found"),
    [
        ("def a():\n    from sassi_bench.rig.sim import truth\n", "sassi_bench.rig.sim.truth"),
        ("def b():\n    from ..rig import sim\n", "sassi_bench.rig.sim"),
        (
            "from ..rig.sim.ground_truth import BenchTruth\n",
            "sassi_bench.rig.sim.ground_truth.BenchTruth",
        ),
        (
            "import importlib\nm = importlib.import_module('sassi_bench.rig.sim')\n",
            "sassi_bench.rig.sim",
        ),
        ("def d():\n    import sassi_bench.rig.sim.bench as bench\n", "sassi_bench.rig.sim.bench"),
        ("x = __import__('sassi_bench.rig.sim')\n", "sassi_bench.rig.sim"),
        (
            "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
            "    from sassi_bench.rig.sim import truth\n",
            "sassi_bench.rig.sim.truth",
        ),
    ],
)
def test_the_parser_sees_lazy_relative_typing_and_dynamic_imports(code, found):
    assert found in imported_names(code, "sassi_bench.workflows.example")


def test_the_table_refuses_the_virtual_bench_to_procedures():
    assert violation("sassi_bench.workflows.full", "sassi_bench.rig.sim.ground_truth")
    assert violation("sassi_bench.snapshot.pipeline", "sassi_bench.calibrate.dispersion")
    assert violation("sassi_bench.rig.config", "sassi_bench.rig.sim.geometry")
    assert violation("sassi_bench.rig", "sassi_bench.rig.sim") is None  # open_rig
    assert violation("sassi_bench.workflows.full", "sassi_bench.rig.rig") is None


def used_edges() -> dict[str, set[str]]:
    """``{row: rows its modules import}``, from the code (a face's own subpackages aside)."""
    used: dict[str, set[str]] = {row: set() for row in TABLE}
    for module, imported in GRAPH.items():
        mine = row_of(module)
        for name in imported:
            theirs = row_of(name)
            if mine and theirs and mine != theirs and violation(module, name) is None:
                used[mine].add(theirs)
    return used


@pytest.mark.parametrize("package", list(TABLE), ids=str)
def test_the_table_permits_only_edges_the_code_uses(package):
    """The table stays the map of the code: an import that goes removes its row's entry."""
    unused = sorted(set(TABLE[package]) - used_edges()[package])
    assert not unused, f"{package} is allowed {unused} but imports none of them; strike them"
