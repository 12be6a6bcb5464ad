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


# --- The bench-only sections of a rig description ------------------------------------

#: Section names only the virtual bench may read (see ``sassi_bench.rig.config``).
BENCH_ONLY = ("as_built", "nuisance")

#: Modules allowed to read them: the virtual bench, and the loader that parses them.
BENCH_ONLY_READERS = ("sassi_bench.rig.sim", "sassi_bench.rig.config")


def bench_only_reads(source: str) -> list[str]:
    """Where ``source`` reads a bench-only section: an attribute (``desc.as_built``), a
    ``getattr`` or a subscript with the section's name as a constant."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in BENCH_ONLY:
            found.append(f"line {node.lineno}: .{node.attr}")
        elif isinstance(node, ast.Call) and getattr(node.func, "id", "") == "getattr":
            args = node.args
            if len(args) > 1 and isinstance(args[1], ast.Constant) and args[1].value in BENCH_ONLY:
                found.append(f"line {node.lineno}: getattr {args[1].value}")
        elif isinstance(node, ast.Subscript):
            key = node.slice
            if isinstance(key, ast.Constant) and key.value in BENCH_ONLY:
                found.append(f"line {node.lineno}: [{key.value!r}]")
    return found


def package_files_outside_the_bench() -> list[Path]:
    return [
        path
        for path in sorted(PACKAGE.rglob("*.py"))
        if not any(
            _module_name(path) == reader or _module_name(path).startswith(reader + ".")
            for reader in BENCH_ONLY_READERS
        )
    ]


@pytest.mark.parametrize(
    "path", package_files_outside_the_bench(), ids=lambda p: str(p.relative_to(PACKAGE))
)
def test_only_the_virtual_bench_reads_as_built_and_nuisance(path):
    assert bench_only_reads(path.read_text()) == []


@pytest.mark.parametrize(
    "code",
    [
        "lines = rig.description.as_built.lasers_nm\n",
        "jitter = getattr(desc, 'nuisance')\n",
        "section = data['as_built']\n",
    ],
)
def test_the_bench_only_guard_sees_attributes_getattr_and_keys(code):
    assert bench_only_reads(code) != []
    assert bench_only_reads("lines = rig.description.lasers_nm\n") == []


def test_bench_only_sections_stay_out_of_what_procedures_record():
    from sassi_bench.rig.config import load_rig_description, rig_description_from_dict

    described = load_rig_description("sim")
    data = described.to_dict()
    data["as_built"] = {"lasers_nm": {"635": 637.8}, "halogen_k": 2900}
    data["nuisance"] = {"hot_pixels_fraction": 1e-4}
    as_built = rig_description_from_dict(data)
    assert as_built.as_built.lasers_nm == {635.0: 637.8}
    assert "as_built" not in as_built.to_dict() and "nuisance" not in as_built.to_dict()
    assert as_built.sha256() == described.sha256()
