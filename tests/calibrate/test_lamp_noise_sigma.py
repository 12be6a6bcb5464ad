"""The map's stated 1-sigma on a lamp-anchored bench includes the lamp streaks' own
photon noise: as large as the spread of maps anchored again on fresh lamp frames."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.calibrate.anchored import fit_anchored_wavelengths
from sassi_bench.calibrate.dispersion import LaserMap, fit_dispersion
from sassi_bench.calibrate.field import fit_field
from tests.calibrate.test_anchored_start import GLASS, SLM, _column, _sigma_px

#: Three lines for the quadratic: the maps leave the joint model no scatter to state, so
#: what is stated is the lamps' noise alone.
TRUE_LINES = {473.0: 473.0, 532.0: 532.0, 635.0: 633.0}


def _exact_maps() -> list[LaserMap]:
    h, w = SLM
    v, u = np.mgrid[0:h:4, 0:w:4].astype(float)
    maps = []
    for label, true in TRUE_LINES.items():
        fx = fit_field(u.ravel(), v.ravel(), _column(u, v, true).ravel(), SLM, 1)
        fy = fit_field(u.ravel(), v.ravel(), (20.0 + 1.01 * v).ravel(), SLM, 1)
        maps.append(LaserMap(label, fx, fy, u.size))
    return maps


def _anchored_fit(build, maps, seed: int):
    rng = np.random.default_rng(seed)
    lamps = [build(name, _column, _sigma_px, rng, amplitude_spread=0.3) for name in ("HgAr", "Ne")]
    anchored = fit_anchored_wavelengths(maps, lamps, GLASS, SLM, [5.0] * 3, field_degree=1)
    # The lines at their true wavelengths: the spread left is the lamps' photon noise.
    return fit_dispersion(
        maps, GLASS, SLM, field_degree=1, wavelengths_nm=TRUE_LINES,
        x_information=anchored.information,
    )  # fmt: skip


def test_the_stated_sigma_carries_the_lamp_streaks_photon_noise(synthetic_lamp_streaks):
    maps = _exact_maps()
    fits = [_anchored_fit(synthetic_lamp_streaks, maps, seed) for seed in range(16)]
    lam = np.linspace(400.0, 700.0, 31)
    centre = ((SLM[1] - 1) / 2, (SLM[0] - 1) / 2)
    columns = np.array([np.ravel(f.model.evaluate(*centre, lam)[0]) for f in fits])
    spread_px = columns.std(axis=0, ddof=1)
    stated_px = np.median([f.position_sigma_rms_px for f in fits])
    spread_rms = float(np.sqrt(np.mean(spread_px**2)))
    # 16 fits give the spread to about a fifth; the maps are exact, so without the
    # lamps' own noise the stated figure would be nothing.
    assert spread_rms > 1e-5
    assert stated_px == pytest.approx(spread_rms, rel=0.4)
