import numpy as np
import pytest

from sassi_bench.optics.glass import refractive_index
from sassi_bench.optics.prism import (
    deviation_deg,
    min_deviation_incidence_deg,
    refract,
    trace_prism,
)


def _deviation_of(out):
    return np.rad2deg(np.arctan2(-out[..., 0], out[..., 2]))


@pytest.mark.parametrize(
    ("n", "apex", "incidence"), [(1.5, 60, 48.0), (1.8, 30, 20.0), (1.6, 45, 35.0)]
)
def test_ray_trace_agrees_with_textbook_deviation(n, apex, incidence):
    out = trace_prism(np.array([0.0, 0.0, 1.0]), n, apex, incidence)
    assert _deviation_of(out) == pytest.approx(float(deviation_deg(n, apex, incidence)), abs=1e-9)


def test_minimum_deviation_is_a_minimum():
    n, apex = 1.7, 30.0
    ti = min_deviation_incidence_deg(n, apex)
    d0 = deviation_deg(n, apex, ti)
    assert np.all(deviation_deg(n, apex, [ti - 2, ti - 0.5, ti + 0.5, ti + 2]) > d0)
    # At minimum deviation the ray crosses the prism symmetrically.
    assert float(d0) == pytest.approx(2 * ti - apex, abs=1e-9)


def test_deviation_increases_with_index_so_blue_bends_more():
    lam = np.linspace(400, 700, 31)
    dev = deviation_deg(refractive_index("N-BK7", lam), 30.0, 20.0)
    assert np.all(np.diff(dev) < 0)


def test_total_internal_reflection_gives_nan():
    assert np.isnan(deviation_deg(1.5, 60.0, 10.0))
    assert np.all(np.isnan(trace_prism(np.array([0.0, 0.0, 1.0]), 1.5, 60.0, 10.0)))


def test_refraction_preserves_unit_length_and_tangential_momentum():
    rng = np.random.default_rng(0)
    d = rng.normal(size=(100, 3)) * [0.2, 0.2, 0.0] + [0, 0, 1]
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    normal = np.array([0.1, 0.0, 1.0]) / np.hypot(0.1, 1.0)
    t = refract(d, normal, 1.0, 1.5)
    assert np.allclose(np.linalg.norm(t, axis=1), 1.0)
    # n1 (d x N) = n2 (t x N): Snell's law in vector form.
    assert np.allclose(np.cross(d, normal), 1.5 * np.cross(t, normal))


def test_skew_rays_keep_their_vertical_direction_cosine():
    d = np.array([0.0, 0.1, 1.0])
    d /= np.linalg.norm(d)
    out = trace_prism(d, 1.6, 30.0, 25.0)
    assert out[1] == pytest.approx(d[1], abs=1e-12)
