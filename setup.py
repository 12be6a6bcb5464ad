"""Package layout that pyproject.toml cannot express, and build provenance.

The lab-editable ``procedures/`` folder is installed as the subpackage
``sassi_bench.procedures``, so rig and procedure YAML resolve the same way from a checkout
and from an installed wheel. A regular (non-editable) build writes
``sassi_bench/_build_info.json`` (version and git commit of the source tree) into the
built package, so bundles published by an installed copy still name their commit; an
editable install asks git at run time instead (see ``sassi_bench/provenance.py``).
"""

import importlib.util
from pathlib import Path

from setuptools import find_packages, setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent


def _provenance():
    """``sassi_bench/provenance.py`` loaded by path (the package's dependencies may be
    missing while it is being built)."""
    spec = importlib.util.spec_from_file_location(
        "_sassi_bench_provenance", ROOT / "sassi_bench" / "provenance.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


class BuildPyWithProvenance(build_py):
    """``build_py`` that also records the version and git commit in the built package."""

    def run(self):
        super().run()
        if not getattr(self, "editable_mode", False):
            _provenance().write_build_info(
                Path(self.build_lib) / "sassi_bench",
                version=self.distribution.get_version(),
                source_root=ROOT,
            )


setup(
    packages=[*find_packages(include=["sassi_bench", "sassi_bench.*"]), "sassi_bench.procedures"],
    package_dir={"sassi_bench.procedures": "procedures"},
    cmdclass={"build_py": BuildPyWithProvenance},
)
