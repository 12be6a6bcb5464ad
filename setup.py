"""Package layout that pyproject.toml cannot express: the lab-editable ``procedures/``
folder is installed as the subpackage ``sassi_bench.procedures``, so rig and procedure
YAML resolve the same way from a checkout and from an installed wheel."""

from setuptools import find_packages, setup

setup(
    packages=[*find_packages(include=["sassi_bench", "sassi_bench.*"]), "sassi_bench.procedures"],
    package_dir={"sassi_bench.procedures": "procedures"},
)
