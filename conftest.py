"""What the package's docstring examples run against (pytest collects them with
``--doctest-modules``).

Every doctest gets, in its namespace, ``np`` and ``bundle``: the synthetic calibration
bundle of the bundle tests (``tests/bundle/conftest.py``: a 640 x 400 SLM on a 2048 x
2048 camera, 68 bins, a guide homography and a response), published once per test
session as versions ``v0001`` and ``v0002`` of rig ``sim`` under a data root of its own,
which ``SASSI_BENCH_DATA`` names while the example runs (so ``load(rig="sim")`` finds
it; ``data`` is its path). Each example runs in a temporary folder of its own, so the
files it writes go there; ``calib_data`` in that folder is the data root. Building the
bundles takes well under a second.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest
from _pytest.doctest import DoctestItem

from sassi_bench.bundle import load

_SYNTHETIC = Path(__file__).parent / "tests" / "bundle" / "conftest.py"


def _synthetic_models():
    """tests/bundle/conftest.py as a module of its own (it is a conftest, not importable)."""
    name = "doctest_bundle_synthetic"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, _SYNTHETIC)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


@pytest.fixture(scope="session")
def doctest_data(tmp_path_factory) -> Path:
    """A data root holding the synthetic bundle (sim/v0001) and, newer, the same
    spectral models alone, with no guide homography nor response (sim/v0002)."""
    root = tmp_path_factory.mktemp("doctest-data")
    synthetic = _synthetic_models()
    synthetic.publish_synthetic(root)
    spectral = synthetic.make_models(guide_to_slm=None, guide_info={}, response=None)
    synthetic.publish_synthetic(root, models=spectral)
    return root


@pytest.fixture(autouse=True)
def _doctest_examples(request, monkeypatch):
    """Fill a doctest's namespace; other tests are left alone (nothing is built for them)."""
    if not isinstance(request.node, DoctestItem):
        return

    data = request.getfixturevalue("doctest_data")
    namespace = request.getfixturevalue("doctest_namespace")
    monkeypatch.setenv("SASSI_BENCH_DATA", str(data))
    folder = request.getfixturevalue("tmp_path")
    (folder / "calib_data").symlink_to(data, target_is_directory=True)
    monkeypatch.chdir(folder)
    namespace.update(np=np, bundle=load(rig="sim", version=1, data=data), data=str(data))
