"""Procedures never see the virtual bench or its ground truth.

Every module file of the consumer packages is parsed (not imported), so imports inside
functions, ``importlib.import_module("...")`` and ``__import__("...")`` with a constant
name are all caught.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import sassi_bench

#: Packages that get device handles only. Add a new consumer package here.
CONSUMERS = ("acquire", "calibrate", "spectra", "workflows", "validate", "snapshot", "batch")

#: What they must not import: the virtual bench and its truth.
FORBIDDEN = ("sassi_bench.rig.sim",)

PACKAGE = Path(sassi_bench.__file__).parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imported_names(source: str, module: str, is_package: bool = False) -> set[str]:
    """Every module name ``source`` (the code of ``module``) imports, anywhere in it,
    resolved to absolute names."""
    tree = ast.parse(source)
    package = module if is_package else module.rsplit(".", 1)[0]
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[: len(anchor) - (node.level - 1)]
                base = ".".join([*anchor, base] if base else anchor)
            names.add(base)
            names.update(f"{base}.{alias.name}" for alias in node.names)
        elif isinstance(node, ast.Call) and node.args:
            func = node.func
            called = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")
            first = node.args[0]
            if called in ("import_module", "__import__") and isinstance(first, ast.Constant):
                names.add(str(first.value))
    return names


def _forbidden(names: set[str]) -> list[str]:
    return sorted(n for n in names if any(n == f or n.startswith(f + ".") for f in FORBIDDEN))


def consumer_files() -> list[Path]:
    files = []
    for package in CONSUMERS:
        folder = PACKAGE / package
        if folder.is_dir():
            files += sorted(folder.rglob("*.py"))
    return files


def test_every_listed_package_is_checked():
    present = {p.relative_to(PACKAGE).parts[0] for p in consumer_files()}
    assert {"acquire", "calibrate", "spectra", "workflows", "validate"} <= present


@pytest.mark.parametrize("path", consumer_files(), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_consumer_modules_do_not_import_the_virtual_bench(path):
    names = imported_names(path.read_text(), _module_name(path), path.name == "__init__.py")
    assert _forbidden(names) == []


@pytest.mark.parametrize(
    ("code", "found"),
    [
        ("def a():\n    from sassi_bench.rig.sim import truth\n", "sassi_bench.rig.sim.truth"),
        ("def b():\n    from ..rig import sim\n", "sassi_bench.rig.sim"),
        ("from ..rig.sim.ground_truth import BenchTruth\n", "sassi_bench.rig.sim.ground_truth"),
        (
            "import importlib\nm = importlib.import_module('sassi_bench.rig.sim')\n",
            "sassi_bench.rig.sim",
        ),
        ("def d():\n    import sassi_bench.rig.sim.bench as bench\n", "sassi_bench.rig.sim.bench"),
        ("x = __import__('sassi_bench.rig.sim')\n", "sassi_bench.rig.sim"),
    ],
)
def test_the_guard_sees_lazy_relative_and_dynamic_imports(code, found):
    assert found in _forbidden(imported_names(code, "sassi_bench.workflows.example"))
    assert (
        _forbidden(imported_names("from ..rig import open_rig\n", "sassi_bench.workflows.x")) == []
    )
