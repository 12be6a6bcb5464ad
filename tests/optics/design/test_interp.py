"""The traced grid's interpolants: exact on cubics, linear beyond the nodes."""

import numpy as np

from sassi_bench.optics.design.interp import GridSpline


def _cubic(u, v, lam):
    t = (lam - 550.0) / 100.0
    return 0.3 * u + 0.01 * u * v - 2e-5 * u**3 + 4.0 * t**3 - t * v / 50.0


def test_cubic_in_each_axis_is_reproduced_between_the_nodes():
    u, v, lam = np.linspace(-20, 660, 9), np.linspace(-10, 410, 7), np.arange(380.0, 731.0, 10.0)
    grid = _cubic(*np.meshgrid(u, v, lam, indexing="ij"))
    spline = GridSpline(u, v, lam, {"q": grid, "twice": 2 * grid})
    rng = np.random.default_rng(3)
    pu, pv = rng.uniform(0, 639, 50), rng.uniform(0, 399, 50)
    pl = rng.uniform(400, 700, 7)
    block = spline.grid(("q", "twice"), pu, pv, pl)
    truth = _cubic(pu[:, None], pv[:, None], pl[None, :])
    np.testing.assert_allclose(block[..., 0], truth, atol=1e-9)
    np.testing.assert_allclose(block[..., 1], 2 * truth, atol=1e-9)
    (points,) = spline.points(("q",), pu, pv, pl[0])
    np.testing.assert_allclose(points, truth[:, 0], atol=1e-9)
    # the coefficients contracted with these wavelengths are kept per (wavelengths,
    # quantities): other points, another order of the names, the same answers
    again = spline.grid(("twice", "q"), pu[::-1], pv[::-1], pl)
    np.testing.assert_allclose(again[..., 1], truth[::-1], atol=1e-9)
    np.testing.assert_allclose(again[..., 0], 2 * truth[::-1], atol=1e-9)


def test_beyond_the_nodes_quantities_continue_linearly():
    u, v, lam = np.linspace(0, 10, 5), np.linspace(0, 5, 4), np.linspace(400, 700, 5)
    U, V, _ = np.meshgrid(u, v, lam, indexing="ij")
    spline = GridSpline(u, v, lam, {"x": 3 * U - V})
    assert spline.at("x", 14.0, -2.0, 550.0) == np.float64(44.0)
