"""The inverse dispersion map against Newton's method at full resolution."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.bundle import load
from sassi_bench.errors import ProcedureError
from sassi_bench.export.camera_lookup import _newton, solve_camera_lookup


@pytest.fixture(scope="module")
def synthetic_bundle(synthetic, tmp_path_factory):
    return load(synthetic.publish_synthetic(tmp_path_factory.mktemp("data")))


@pytest.mark.parametrize("step", [8, 16])
def test_interpolated_lookup_matches_newton(synthetic_bundle, step):
    """Bilinear interpolation between exactly solved nodes, against each pixel solved on
    its own (2.8 camera px per SLM px, so the map's curvature per camera px is small)."""
    bundle = synthetic_bundle
    lam = np.array([420.0, 560.0, 690.0])
    lookup = solve_camera_lookup(bundle, (2048, 2048), lam, step=step)
    rng = np.random.default_rng(1)
    for t, wavelength in enumerate(lam):
        u, v = lookup.band(t)
        rows, cols = np.nonzero(np.isfinite(u))
        pick = rng.choice(rows.size, 3000)
        r, c = rows[pick], cols[pick]
        exact_u, exact_v = _newton(
            bundle, wavelength, c.astype(float), r.astype(float), u[r, c] + 0.0, v[r, c] + 0.0
        )
        assert np.abs(exact_u - u[r, c]).max() < 0.002
        assert np.abs(exact_v - v[r, c]).max() < 0.002


def test_reach_follows_the_slm_edges(synthetic_bundle):
    bundle = synthetic_bundle
    lookup = solve_camera_lookup(bundle, (2048, 2048), [550.0])
    u, v = lookup.band(0)
    h, w = bundle.slm_shape
    reached = np.isfinite(u)
    assert np.array_equal(reached, np.isfinite(v))
    assert u[reached].min() >= -0.5 and u[reached].max() <= w - 0.5
    assert v[reached].min() >= -0.5 and v[reached].max() <= h - 0.5
    # The SLM's image (scale 2.8) covers about 1790 x 1120 camera px.
    area = reached.sum() / (1790 * 1120)
    assert 0.97 < area < 1.03


def test_bad_arguments(synthetic_bundle):
    with pytest.raises(ProcedureError, match="too small"):
        solve_camera_lookup(synthetic_bundle, (1, 10))
    with pytest.raises(ProcedureError, match="not a list"):
        solve_camera_lookup(synthetic_bundle, (64, 64), [])
