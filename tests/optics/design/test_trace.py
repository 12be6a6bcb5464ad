"""Tracing a design with optiland: quadrature, symmetry, the cache (needs the extra)."""

import numpy as np
import pytest

from sassi_bench.optics.design import OpticalDesign, design_relay
from sassi_bench.optics.design.cache import cache_key, cached_trace
from sassi_bench.optics.design.trace import GridSpec, pupil_quadrature

pytest.importorskip("optiland", reason='the optiland ray tracer: pip install "sassi-bench[design]"')

# A centred 4f relay of two N-BK7 singlets (no prism): symmetric about the axis.
RELAY = {
    "slm_pixel_pitch_um": 8.0,
    "camera_pixel_pitch_um": 5.5,
    "object_distance_mm": 22.7,
    "aperture": {"object_space_na": 0.02},
    "surfaces": [
        {"thickness_mm": 3.5, "material": "N-BK7", "diameter_mm": 12.7},
        {"radius_mm": -12.92, "thickness_mm": 20.0},
        {"thickness_mm": 20.0, "stop": True},
        {"radius_mm": 12.92, "thickness_mm": 3.5, "material": "N-BK7"},
        {"thickness_mm": 22.5},
    ],
}
SPEC = GridSpec((40, 64), (64, 96), 500.0, 600.0, 50.0, columns=5, rows=4, rings=3)


def test_quadrature_integrates_the_disc_moments_exactly():
    px, py, w = pupil_quadrature(3)
    r2 = px**2 + py**2
    assert np.sum(w) == pytest.approx(1.0)
    assert np.sum(w * r2) == pytest.approx(0.5)  # mean r**2 over the unit disc
    assert np.sum(w * r2**2) == pytest.approx(1.0 / 3.0)
    assert np.sum(w * px * py) == pytest.approx(0.0, abs=1e-15)


def test_a_centred_relay_is_symmetric_and_cached(tmp_path, monkeypatch):
    design = OpticalDesign.from_mapping(RELAY)
    grid = cached_trace(design, SPEC, folder=tmp_path)
    assert (tmp_path / f"{cache_key(design, SPEC)}.npz").is_file()
    # inverted image of a centred system: the field's mirror lands mirrored about the centre
    cx, cy = (96 - 1) / 2, (64 - 1) / 2
    np.testing.assert_allclose(grid.x + grid.x[::-1, ::-1], 2 * cx, atol=1e-6)
    np.testing.assert_allclose(grid.y + grid.y[::-1, ::-1], 2 * cy, atol=1e-6)
    assert np.all(grid.throughput == pytest.approx(1.0))
    assert np.all(grid.sxx > 0) and np.all(grid.syy > 0)
    # read back from the cache, without tracing again
    monkeypatch.setattr(
        "sassi_bench.optics.design.cache.trace_grid",
        lambda *a, **k: pytest.fail("traced again despite the cache"),
    )
    again = cached_trace(design, SPEC, folder=tmp_path)
    np.testing.assert_array_equal(again.x, grid.x)
    np.testing.assert_array_equal(again.sxy, grid.sxy)


def test_design_relay_inverts_its_own_map(tmp_path, monkeypatch):
    monkeypatch.setenv("SASSI_BENCH_DESIGN_CACHE", str(tmp_path))
    relay = design_relay(
        OpticalDesign.from_mapping(RELAY), (40, 64), (64, 96), (500.0, 600.0), progress=None
    )
    x, y = relay.forward([3.0, 60.0], [5.0, 33.0], 550.0)
    u, v = relay.inverse(x, y, 550.0)
    np.testing.assert_allclose(u, [3.0, 60.0], atol=1e-6)
    np.testing.assert_allclose(v, [5.0, 33.0], atol=1e-6)
    # 4f relay of equal lenses: unit magnification, camera px per SLM px = 8 / 5.5
    assert relay.scale == pytest.approx(8.0 / 5.5, rel=0.02)
