"""Shared fixtures: simulated rigs are opened once per test session."""

from __future__ import annotations

import pytest

from sassi_bench import open_rig
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict


@pytest.fixture(scope="session")
def sim_rig():
    """The default virtual bench (tests set the scene, light and pattern they need)."""
    return open_rig("sim")


@pytest.fixture()
def sim_dict():
    """The default rig description as a mutable dict, for building odd rigs."""
    return load_rig_description("sim").to_dict()


@pytest.fixture()
def make_rig():
    """Open a rig from a (modified) description dict."""

    def _make(data: dict):
        return open_rig(rig_description_from_dict(data))

    return _make


@pytest.fixture(scope="session")
def calibrated_sim(tmp_path_factory):
    """The default virtual bench, spectrally calibrated once per test session.

    Returns (rig, result, data_root); the bundle is published under data_root.
    """
    from sassi_bench.workflows.procedure import load_procedure
    from sassi_bench.workflows.spectral import run_spectral_calibration

    rig = open_rig("sim")
    data = tmp_path_factory.mktemp("calibrated-sim")
    result = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=data, progress=False, session_id="acc"
    )
    return rig, result, data
