"""Procedures never read a rig's bench-only sections (``as_built``, ``nuisance``): how the
virtual bench differs from its description is for the bench alone.

Every module file of the package is parsed (not imported). That procedures never import the
virtual bench or its ground truth is the layer table's rule (``tests/test_layers.py``).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import sassi_bench

PACKAGE = Path(sassi_bench.__file__).parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


# --- The bench-only sections of a rig description ------------------------------------

#: Section names only the virtual bench may read, and where the description keeps them
#: (see ``sassi_bench.rig.sim.sections``).
BENCH_ONLY = ("as_built", "nuisance", "bench_sections")

#: Modules allowed to read them: the virtual bench, and the loader that sets them apart.
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
    from sassi_bench.rig.sim.sections import as_built_section

    described = load_rig_description("sim")
    data = described.to_dict()
    data["as_built"] = {"lasers_nm": {"635": 637.8}, "halogen_k": 2900}
    data["nuisance"] = {"hot_pixels_fraction": 1e-4}
    as_built = rig_description_from_dict(data)
    assert as_built_section(as_built).lasers_nm == {635.0: 637.8}
    assert "as_built" not in as_built.to_dict() and "nuisance" not in as_built.to_dict()
    assert as_built.sha256() == described.sha256()
