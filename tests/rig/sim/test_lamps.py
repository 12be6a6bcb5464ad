"""Wavelength lamps on the virtual bench: lines rendered where the truth puts them."""

import numpy as np
import pytest

from sassi_bench.optics.lamps import load_line_list
from sassi_bench.rig.sim import truth


def _pinhole_rate(rig, light: str, u: int, v: int) -> np.ndarray:
    bench = truth(rig).bench
    pattern = np.zeros(rig.slm.shape, np.uint8)
    pattern[v, u] = 255
    bench.set_scene("white")
    bench.set_light(light)
    bench.pattern = pattern
    closed = bench._background_rate()
    return bench.spectral_rate() - closed


def test_an_isolated_line_lands_at_its_true_column(sim_rig):
    t = truth(sim_rig)
    rate = _pinhole_rate(sim_rig, "lamp:HgAr", 320, 200)
    x, y = t.slm_to_camera(320, 200, 546.075)
    row = round(float(y))
    profile = rate[row - 6 : row + 7].sum(axis=0)
    cols = np.arange(profile.size)
    near = np.abs(cols - x) <= 3
    centroid = float((profile[near] * cols[near]).sum() / profile[near].sum())
    assert centroid == pytest.approx(float(x), abs=0.03)


def test_the_mercury_doublet_blends_into_one_peak(sim_rig):
    t = truth(sim_rig)
    (x577, x579), (y, _) = t.slm_to_camera(320, 200, np.array([576.961, 579.067]))
    assert x579 - x577 < 0.5  # closer than the spot's width: one peak on this bench
    rate = _pinhole_rate(sim_rig, "lamp:HgAr", 320, 200)
    profile = rate[round(float(y)) - 6 : round(float(y)) + 7].sum(axis=0)
    window = profile[int(x577) - 4 : int(x579) + 6]
    peaks = np.nonzero((window[1:-1] > window[:-2]) & (window[1:-1] >= window[2:]))[0]
    assert peaks.size == 1


def test_a_lamp_as_built_is_off_its_table_by_a_fixed_spread(make_rig, sim_dict):
    sim_dict["as_built"] = {"lamp_intensity_spread": 0.3}
    rig = make_rig(sim_dict)
    table = load_line_list("HgAr").relative_intensity
    true = truth(rig).lamp_lines("HgAr").relative_intensity
    ratio = np.log(true / table)
    assert 0.1 < np.std(ratio) < 0.6
    assert np.array_equal(true, truth(make_rig(sim_dict)).lamp_lines("HgAr").relative_intensity)
    weights = truth(rig).light_samples("lamp:HgAr").weights
    assert np.allclose(weights / weights.max(), true / true.max())
