"""The snapshot package is a bundle consumer: it must not reach fitting code or bench truth."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import sassi_bench.snapshot

FORBIDDEN = ("sassi_bench.rig.sim", "sassi_bench.calibrate", "sassi_bench.validate",
             "sassi_bench.workflows")  # fmt: skip


def test_snapshot_imports_only_the_bundle_api_and_spectra():
    folder = Path(sassi_bench.snapshot.__file__).parent
    for path in folder.glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            for name in names:
                if name.startswith("sassi_bench."):
                    top = name.split(".")[1]
                    assert top in ("bundle", "errors", "spectra", "snapshot"), (path.name, name)


def test_importing_snapshot_loads_no_fitting_code_nor_bench_truth():
    code = (
        "import sys, sassi_bench.snapshot; "
        "print('\\n'.join(m for m in sys.modules if m.startswith('sassi_bench.')))"
    )
    loaded = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split()
    assert "sassi_bench.snapshot.reconstruct" in loaded
    assert not [m for m in loaded if m.startswith(FORBIDDEN)]
