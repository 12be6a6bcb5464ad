"""Small plans, synthetic frames and a data root in ``tmp_path`` for the acquisition tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.rig.config import RigDescription, load_rig_description
from sassi_bench.rig.frame import Frame, FrameMeta

SPECTRAL_SHAPE = (6, 8)
GUIDE_SHAPE = (4, 5, 3)


def _pinhole_step(offset_x: int, light: str = "laser:532", camera: str = "spectral") -> Step:
    """A spectral pinhole frame tagged with its offset."""
    return Step(
        camera,
        light,
        0.01,
        {"kind": "pinholes", "pitch": [100, 50], "offset": [offset_x, 0]},
        {"role": "pinholes", "offset_x": offset_x},
    )


def _make_frame(camera: str = "spectral", value: int = 0, shape=None, index: int = 0) -> Frame:
    """A synthetic frame with distinct pixels (``value`` shifts them)."""
    shape = shape or (SPECTRAL_SHAPE if camera == "spectral" else GUIDE_SHAPE)
    data = (np.arange(np.prod(shape), dtype=np.uint16).reshape(shape) + value).astype(np.uint16)
    meta = FrameMeta(camera, 0.01, 1_700_000_000.0 + index, index, "laser:532", index, {})
    return Frame(data, meta)


@pytest.fixture(name="pinhole_step")
def pinhole_step_fixture():
    """``pinhole_step(offset_x, light=..., camera=...)`` -> Step."""
    return _pinhole_step


@pytest.fixture(name="make_frame")
def make_frame_fixture():
    """``make_frame(camera, value, shape, index)`` -> Frame."""
    return _make_frame


@pytest.fixture(scope="session")
def rig_description() -> RigDescription:
    return load_rig_description("sim")


@pytest.fixture()
def data(tmp_path: Path) -> Path:
    """The data root for one test (never the repository's calib_data/)."""
    return tmp_path / "data"


@pytest.fixture()
def mixed_plan() -> Plan:
    """Spectral and guide steps interleaved: slots are per-camera ranks."""
    guide = Step("guide", "led", 0.02, {"kind": "blank"}, {"role": "guide"})
    return Plan(
        "mixed",
        (_pinhole_step(0), guide, _pinhole_step(1), _pinhole_step(2), guide),
        {"pitch": [100, 50]},
    )
