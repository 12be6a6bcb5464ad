"""The virtual bench's optics drifting with time (``nuisance.drift``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.errors import ConfigError
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim import truth
from sassi_bench.rig.sim.sections import nuisance_section

RIG = Path(__file__).parents[2] / "rigs" / "nuisance-drift.yaml"


def _at(hours: float):
    data = load_rig_description(RIG).to_dict()
    data["nuisance"] = {"drift": {"start_h": hours, "relay_offset_px_per_h": [0.0333, 0.01]}}
    return open_rig(rig_description_from_dict(data))


def test_drift_is_bench_only_and_keeps_the_rig_hash():
    desc = load_rig_description(RIG)
    assert nuisance_section(desc).drift.relay_offset_px_per_h == (0.0333, 0.01)
    assert "nuisance" not in desc.to_dict()
    assert desc.sha256() == load_rig_description(RIG).sha256()
    data = desc.to_dict()
    data["nuisance"] = {"drift": {"start_h": 6.0}}
    assert rig_description_from_dict(data).sha256() == desc.sha256()


def test_a_bench_opened_at_15_00_is_off_by_the_rate_times_six_hours():
    morning, afternoon = _at(0.0), _at(6.0)
    u, v = np.array([0.0, 319.5, 639.0]), np.array([0.0, 199.5, 399.0])
    x0, y0 = truth(morning).slm_to_camera(u, v, 550.0)
    x6, y6 = truth(afternoon).slm_to_camera(u, v, 550.0)
    assert truth(afternoon).clock_h == 6.0
    np.testing.assert_allclose(x6 - x0, 0.0333 * 6, atol=1e-6)
    np.testing.assert_allclose(y6 - y0, 0.01 * 6, atol=1e-6)


def test_the_clock_advances_with_every_frame_and_the_walk_is_seeded():
    rig = open_rig(RIG)
    t = truth(rig)
    rig.spectral_camera.set_exposure(0.5)
    for _ in range(3):
        rig.spectral_camera.capture()
    assert t.clock_h == pytest.approx(3 * 0.55 / 3600)
    later = t.drift_at(2.0)
    assert later == truth(open_rig(RIG)).drift_at(2.0)
    assert later.rotation_deg == pytest.approx(0.004)
    assert later.tilt_deg == pytest.approx(0.002)
    assert later.offset_px[0] != pytest.approx(0.0666, abs=1e-9)  # the random walk
    t.set_clock(2.0)
    x, _ = t.slm_to_camera(639.0, 399.0, 650.0)
    t.set_clock(0.0)
    x0, _ = t.slm_to_camera(639.0, 399.0, 650.0)
    assert 0.02 < float(x - x0) < 0.2


def test_drift_on_a_hardware_rig_or_an_unknown_key_is_refused():
    data = load_rig_description(RIG).to_dict()
    data["nuisance"] = {"drift": {"rate": 1.0}}
    with pytest.raises(ConfigError, match="drift"):
        rig_description_from_dict(data)
