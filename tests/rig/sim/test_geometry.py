from pathlib import Path

import numpy as np
import pytest

from sassi_bench.rig.config import load_rig_description
from sassi_bench.rig.sim.geometry import bench_relay

RIGS = Path(__file__).parents[2] / "rigs"


def _streaks(relay):
    u, v = np.meshgrid(np.linspace(0, 639, 5), np.linspace(0, 399, 4))
    return relay.forward(u[..., None], v[..., None], np.linspace(400, 700, 7))


def test_a_bench_built_as_described_traces_the_described_relay():
    desc = load_rig_description("sim")
    np.testing.assert_allclose(
        _streaks(bench_relay(desc)), _streaks(desc.nominal_relay()), rtol=0, atol=1e-6
    )


def test_a_bench_built_with_another_prism_traces_the_true_prism():
    desc = load_rig_description(RIGS / "as-built-glass.yaml")
    built, described = bench_relay(desc), desc.nominal_relay()
    assert built.apex_deg == pytest.approx(30.4)
    assert built.glass.index(550.0) == pytest.approx(described.glass.index(550.0) + 0.003)
    # Aligned as described (focal length, roll), so the streaks differ from the description.
    assert (built.f2, built.roll_rad) == (described.f2, described.roll_rad)
    x, _ = built.forward(319.5, 199.5, np.array([400.0, 700.0]))
    assert abs((x[1] - x[0]) - desc.prism.spread_px) > 0.5
