"""``sassi-bench --help``, ``--version`` and an argument error answer at once: building the
parser loads argparse and the command modules, none of the scientific stack (its timing
goal, under 0.5 s, is measured by ``benchmarks/bench_cli_startup.py``)."""

from __future__ import annotations

import subprocess
import sys

import pytest

#: Modules that take tenths of a second to import; none is needed to parse arguments.
HEAVY = ("numpy", "scipy", "xarray", "matplotlib", "zarr", "numba", "cv2", "colour", "dask")


def _imported(*argv: str) -> set[str]:
    """Modules a fresh ``python -m sassi_bench ARGV`` imports (``-X importtime``)."""
    done = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "sassi_bench", *argv],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    names = set()
    for line in done.stderr.splitlines():
        if line.startswith("import time:") and "|" in line:
            names.add(line.rsplit("|", 1)[1].strip())
    return names


@pytest.mark.parametrize(
    "argv", [("--help",), ("--version",), ("scan", "--bogus"), ("validate", "macbeth", "--help")]
)
def test_help_version_and_argument_errors_load_no_scientific_module(argv):
    loaded = _imported(*argv)
    assert "sassi_bench.commands" in loaded and "argparse" in loaded
    heavy = {name for name in loaded if name.split(".")[0] in HEAVY}
    assert not heavy, sorted(heavy)


def test_the_version_is_looked_up_only_when_asked():
    assert "importlib.metadata" not in _imported("--help")  # slow to import
    done = subprocess.run(
        [sys.executable, "-m", "sassi_bench", "--version"], capture_output=True, text=True,
        timeout=120,
    )  # fmt: skip
    from sassi_bench.provenance import package_version

    assert done.returncode == 0 and done.stdout.strip() == f"sassi-bench {package_version()}"
