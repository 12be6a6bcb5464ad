"""A design rig's neighbouring wavelength samples drawn as one spot: the same moments,
and the frame within 1e-3 of its peak of the sample-by-sample frame."""

import numpy as np
import pytest

from sassi_bench.acquire.patterns import pinhole_pattern
from sassi_bench.rig.sim import design_render, truth
from sassi_bench.rig.sim._spot_merge import merge_neighbouring_spots

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


def _random_spots(rng, pixels=5, samples=40):
    """Streaks of spots 0.3 px apart, of slowly changing, correlated covariance."""
    step = np.linspace(0.0, 0.3 * samples, samples)
    x = 20.0 + step[None, :] + rng.uniform(-2, 2, (pixels, 1))
    y = 10.0 + 0.02 * step[None, :] + rng.uniform(-2, 2, (pixels, 1))
    cxx = 1.0 + 0.05 * step[None, :] + 0 * x
    cyy = 0.8 + 0.02 * step[None, :] + 0 * x
    cxy = 0.3 + 0 * x
    weights = rng.uniform(0.5, 2.0, (pixels, samples))
    weights[0, 3:6] = 0.0  # a dark stretch
    return x, y, cxx, cyy, cxy, weights


def _moments(x, y, cxx, cyy, cxy, w):
    """Energy, centroid and second moments of a sum of Gaussians."""
    total = w.sum()
    mx, my = (w * x).sum() / total, (w * y).sum() / total
    sxx = (w * (cxx + (x - mx) ** 2)).sum() / total
    syy = (w * (cyy + (y - my) ** 2)).sum() / total
    sxy = (w * (cxy + (x - mx) * (y - my))).sum() / total
    return np.array([total, mx, my, sxx, syy, sxy])


def test_merging_keeps_each_pixels_energy_centroid_and_second_moments():
    spots = _random_spots(np.random.default_rng(3))
    merged = merge_neighbouring_spots(*spots)
    assert merged[0].shape[0] == 1
    assert spots[0].size / 4 < merged[0].size < spots[0].size / 1.5  # merged, not all
    assert (merged[5] > 0).all()  # the dark stretch draws nothing
    # pixel by pixel: the merged spots of each streak (in order) have its moments
    counts = [merge_neighbouring_spots(*(a[p : p + 1] for a in spots))[0].size for p in range(5)]
    ends = np.cumsum([0, *counts])
    for p in range(5):
        got = _moments(*(m[0, ends[p] : ends[p + 1]] for m in merged))
        want = _moments(*(a[p] for a in spots))
        np.testing.assert_allclose(got, want, rtol=1e-10, atol=1e-10)


def test_spots_farther_apart_than_the_span_stay_apart():
    x = np.array([[10.0, 10.5, 11.0, 30.0]])
    one = np.ones_like(x)
    merged = merge_neighbouring_spots(x, one, 0.25 * one, 0.25 * one, 0 * one, one)
    # sigma = sqrt(0.25 + 1/12) = 0.577 px: 0.75 sigma = 0.43 px, so no two merge
    assert merged[0].size == 4
    wide = merge_neighbouring_spots(x, one, 4 * one, 4 * one, 0 * one, one)
    # sigma = 2.02 px: 1.5 px spans fit, 20 px does not
    np.testing.assert_allclose(wide[0], [[10.5, 30.0]])
    assert wide[2][0, 0] == pytest.approx(4 + 1 / 6)


@pytest.mark.parametrize("name", ["achromat", "singlet"])
@pytest.mark.parametrize(("light", "scene"), [("led", "colorchecker"), ("halogen", "white")])
def test_a_pinhole_frame_stays_within_1e_3_of_its_peak(
    design_rigs, monkeypatch, name, light, scene
):
    bench = truth(design_rigs(name)).bench
    rows, cols = np.nonzero(pinhole_pattern(bench.slm_shape, (100, 5), (3, 2)))
    args = (
        rows,
        cols,
        np.ones(rows.size, np.float32),
        bench.scene_named(scene),
        bench.samples(light),
    )
    merged = bench.renderer.render_sparse(*args)
    monkeypatch.setattr(design_render, "merge_neighbouring_spots", lambda *spots: spots)
    each = bench.renderer.render_sparse(*args)
    peak = float(each.max())
    # measured 5.5e-4 to 8.0e-4 of the peak on these four frames
    assert np.abs(merged - each).max() < 1e-3 * peak
    assert merged.sum() == pytest.approx(float(each.sum()), rel=1e-5)
