"""The design bench's spot splat: profiles read from the table land as the CDF path
computes them, column by column."""

import numpy as np

from sassi_bench.rig.sim._gauss_splat import profile_table, splat_gaussians


def _spots(rng, count):
    """Spots of every kind the design rigs render (and some they do not): round and
    elongated, correlated up to 0.85, narrower and wider than the table, some cut by the
    frame's edges."""
    sx = rng.uniform(0.3, 4.0, count)
    sy = rng.uniform(0.3, 4.0, count)
    sx[:4] = [0.02, 9.0, 12.0, 0.2]  # outside the table's widths: the CDF path
    rho = rng.uniform(-0.85, 0.85, count)
    x = rng.uniform(-3.0, 63.0, count)
    y = rng.uniform(-3.0, 43.0, count)
    cov = (sx**2, sy**2, rho * sx * sy)
    weights = rng.uniform(0.5, 2.0, count)
    return [a[:, None] for a in (x, y, *cov, weights)]


def _moments(frame):
    rows, cols = np.indices(frame.shape)
    total = frame.sum()
    mx, my = (frame * cols).sum() / total, (frame * rows).sum() / total
    cxx = (frame * (cols - mx) ** 2).sum() / total
    cyy = (frame * (rows - my) ** 2).sum() / total
    cxy = (frame * (cols - mx) * (rows - my)).sum() / total
    return np.array([total, mx, my, cxx, cyy, cxy])


def test_the_table_matches_the_cdf_path():
    rng = np.random.default_rng(11)
    spots = _spots(rng, 60)
    fast = np.zeros((40, 60), np.float32)
    exact = np.zeros((40, 60), np.float32)
    splat_gaussians(*spots, fast)
    splat_gaussians(*spots, exact, tabulated=False)
    peak = float(exact.max())
    # measured 4.0e-4 of the peak, from the narrowest spots (sigma < 0.9 px); 3.5e-5 and
    # 7.4e-5 on a pinhole frame of the design rigs
    assert np.abs(fast - exact).max() < 5e-4 * peak
    # each spot alone: its energy, centroid and covariance as the CDF path gives them
    checked = 0
    for p in range(60):
        one = [a[p : p + 1] for a in spots]
        alone_fast = np.zeros((40, 60), np.float32)
        alone_exact = np.zeros((40, 60), np.float32)
        splat_gaussians(*one, alone_fast)
        splat_gaussians(*one, alone_exact, tabulated=False)
        if alone_exact.sum() < 0.5 * one[-1][0, 0]:
            continue  # mostly off the frame
        checked += 1
        got, want = _moments(alone_fast), _moments(alone_exact)
        assert abs(got[0] / want[0] - 1) < 5e-5  # energy; measured 1.1e-5
        np.testing.assert_allclose(got[1:3], want[1:3], atol=5e-4)  # px; measured 8.9e-5
        np.testing.assert_allclose(got[3:], want[3:], atol=1.5e-3)  # px**2; measured 7.2e-4
    assert checked > 40


def test_the_table_holds_pixel_integrated_profiles():
    table = profile_table()
    assert np.all(np.diff(table.sigmas) > 0)
    n = int(np.searchsorted(table.sigmas, 2.0))
    centred = table.taps[n, table.phases // 2].astype(np.float64)
    j = np.arange(centred.size) - table.centre
    # a centred profile: unit sum (but the 4-sigma cut), zero mean, variance sigma**2 + 1/12
    assert abs(centred.sum() - 1) < 1e-4
    assert abs((j * centred).sum()) < 1e-6
    assert abs((j**2 * centred).sum() - table.sigmas[n] ** 2 - 1 / 12) < 5e-3
    # zeros beyond the cut and around the taps, so rows read whole vectors
    assert not centred[np.abs(j) > table.reach[n]].any()
    assert not table.taps[..., : table.centre - int(table.reach.max())].any()


def test_spots_crossing_bands_land_once():
    # Spots are binned by band before drawing: every row of a spot that crosses band
    # borders, sits at the frame's edge or off it, lands once; a zero weight draws nothing.
    rng = np.random.default_rng(5)
    spots = _spots(rng, 40)
    spots[-1][5, 0] = 0.0  # a spot of no energy
    spots[1][6, 0] = -30.0  # a spot entirely above the frame
    together = np.zeros((96, 60), np.float32)  # 16 bands of 6 rows (transposed: of 4)
    splat_gaussians(*spots, together)
    alone = np.zeros((96, 60), np.float64)
    for p in range(40):
        one = np.zeros((96, 60), np.float32)
        splat_gaussians(*[a[p : p + 1] for a in spots], one)
        if p in (5, 6):
            assert not one.any()
        alone += one
    # float32 sums in another order: measured 4.8e-8 of the peak
    assert np.abs(together - alone).max() < 1e-6 * alone.max()


def test_each_spot_lands_with_its_own_moments():
    # A spot inside the frame, wide or tall, deposits its energy at its centre with its
    # covariance plus the camera pixel's box (1/12 px**2 on each axis), less what the
    # 4 sigma cut removes.
    # Sigmas from 0.7 px: a narrower spot's binned moments alias (Sheppard's corrections
    # hold to exp(-2 pi**2 sigma**2), 6e-5 at 0.7 px).
    rng = np.random.default_rng(7)
    for tabulated in (True, False):
        for _ in range(24):
            sx, sy = rng.uniform(0.7, 3.5, 2)
            rho = rng.uniform(-0.8, 0.8)
            x, y = rng.uniform(25.0, 35.0, 2)
            spot = [np.array([[v]]) for v in (x, y, sx**2, sy**2, rho * sx * sy, 2.0)]
            frame = np.zeros((60, 60), np.float32)
            splat_gaussians(*spot, frame, tabulated=tabulated)
            got = _moments(frame)
            assert abs(got[0] / 2.0 - 1) < 1e-4  # the cut removes at most 6e-5
            np.testing.assert_allclose(got[1:3], [x, y], atol=1e-3)
            # a 4 sigma cut narrows a normal's variance by 0.11 %
            want = np.array([sx**2 + 1 / 12, sy**2 + 1 / 12, rho * sx * sy])
            np.testing.assert_allclose(got[3:], want, rtol=3e-3, atol=2e-3)
