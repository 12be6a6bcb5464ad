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
