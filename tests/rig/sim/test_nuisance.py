"""The virtual bench's real-bench nuisances: one test rig per nuisance and one with all.

Each rig in ``tests/rigs/nuisance-*.yaml`` is ``procedures/rigs/sim.yaml`` with one
``nuisance`` key set; the physics of each is checked here on noise-free electron rates
(exact) and on captured frames (statistically).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.rig.config import load_rig_description
from sassi_bench.rig.sim import truth
from sassi_bench.rig.sim.sections import nuisance_section

RIGS = Path(__file__).parents[2] / "rigs"
NUISANCES = {
    "jitter": "laser_power_jitter",
    "hot-pixels": "hot_pixels_fraction",
    "crosstalk": "slm_crosstalk",
    "stray-light": "stray_light",
    "speckle": "speckle_contrast",
}


def rig_file(name: str) -> Path:
    return RIGS / f"{name}.yaml"


@pytest.fixture(scope="module")
def rigs():
    """One open rig per nuisance, plus the default for comparison."""
    opened = {name: open_rig(rig_file(f"nuisance-{name}")) for name in NUISANCES}
    opened["sim"] = open_rig("sim")
    return opened


def pinholes(shape: tuple[int, int], pitch: int = 40) -> np.ndarray:
    pattern = np.zeros(shape, np.uint8)
    pattern[pitch // 2 :: pitch, pitch // 2 :: pitch] = 255
    return pattern


@pytest.mark.parametrize("name", [*NUISANCES, "all"])
def test_nuisance_rigs_are_the_default_rig_plus_their_nuisance(name):
    desc = load_rig_description(rig_file(f"nuisance-{name}"))
    sim = load_rig_description("sim")
    ignore = {"name", "description"}
    assert {k: v for k, v in desc.to_dict().items() if k not in ignore} == {
        k: v for k, v in sim.to_dict().items() if k not in ignore
    }
    switched_on = {k for k, v in vars(nuisance_section(desc)).items() if v}
    assert switched_on == (set(NUISANCES.values()) if name == "all" else {NUISANCES[name]})


def test_laser_frames_jitter_by_the_rigs_rms_and_lamp_frames_do_not(rigs):
    def frame_levels(rig, light: str, frames: int = 24) -> np.ndarray:
        rig.slm.show(pinholes(rig.slm.shape))
        rig.light.select(light)
        rig.spectral_camera.set_exposure(0.02)
        data = np.stack([rig.spectral_camera.capture().as_float() for _ in range(frames)])
        lit = data.mean(axis=0) > np.percentile(data.mean(axis=0), 90)
        level = (data[:, lit] - 100.0).mean(axis=1)
        return level / level.mean()

    jitter = nuisance_section(rigs["jitter"].description).laser_power_jitter
    spread = float(np.std(frame_levels(rigs["jitter"], "laser:532"), ddof=1))
    assert 0.5 * jitter < spread < 1.6 * jitter  # 24 frames: the RMS within about +-30 %
    assert np.std(frame_levels(rigs["sim"], "laser:532"), ddof=1) < 0.1 * jitter
    assert np.std(frame_levels(rigs["jitter"], "led"), ddof=1) < 0.1 * jitter


def test_hot_pixels_are_fixed_and_bright_in_the_dark(rigs):
    rig = rigs["hot-pixels"]
    rig.light.select("off")
    rig.spectral_camera.set_exposure(0.5)
    first, second = (rig.spectral_camera.capture().as_float() for _ in range(2))
    # The coolest hot pixel collects 3 % of the full well per second: 450 e- in 0.5 s,
    # 90 times the read noise.
    threshold = 100.0 + 40 * 5.0 * 65435 / 30000
    hot = first > threshold
    fraction = nuisance_section(rig.description).hot_pixels_fraction
    assert hot.sum() == round(fraction * first.size)
    assert np.array_equal(hot, second > threshold)
    assert np.array_equal(hot, truth(rig).bench.nuisance.hot_pixel_rate > 0)
    assert (first.max() - 100) * 30000 / 65435 > 0.9 * 30000  # the hottest saturate
    rigs["sim"].light.select("off")
    rigs["sim"].spectral_camera.set_exposure(0.5)
    assert not np.any(rigs["sim"].spectral_camera.capture().as_float() > threshold)


def test_crosstalk_lights_the_four_neighbours_of_an_open_pixel(rigs):
    c = nuisance_section(rigs["crosstalk"].description).slm_crosstalk
    leaky, clean = truth(rigs["crosstalk"]).bench, truth(rigs["sim"]).bench

    def rate(bench, pixels) -> np.ndarray:
        pattern = np.zeros(bench.slm_shape, np.uint8)
        for r, col in pixels:
            pattern[r, col] = 255
        bench.set_light("laser:532")
        bench.pattern = pattern
        return bench.spectral_rate().astype(np.float64) - bench._background_rate()

    centre = (200, 320)
    neighbours = [(199, 320), (201, 320), (200, 319), (200, 321)]
    expected = (1 - 4 * c) * rate(clean, [centre]) + c * sum(rate(clean, [n]) for n in neighbours)
    measured = rate(leaky, [centre])
    np.testing.assert_allclose(measured, expected, atol=1e-4 * expected.max())
    # Dense patterns (the sweeps) get the same crosstalk: a uniform field is unchanged
    # inside, and only light spilled past the SLM's border is lost.
    full = np.full(leaky.slm_shape, 255, np.uint8)
    shown, eps = leaky.slm_transmission(full), leaky.eps
    np.testing.assert_allclose(
        shown[1:-1, 1:-1], clean.slm_transmission(full)[1:-1, 1:-1], rtol=1e-6
    )
    np.testing.assert_allclose(shown[0, 1:-1], eps + (1 - eps) * (1 - c), rtol=1e-6)


def test_stray_light_spreads_a_fraction_of_the_frame_over_the_sensor(rigs):
    rig = rigs["stray-light"]
    f = nuisance_section(rig.description).stray_light
    nuisance = truth(rig).bench.nuisance
    rate = np.zeros(truth(rig).bench.camera_shape, np.float32)
    rate[100:110, 200:300] = 1e5
    out = nuisance.spectral_rate(rate, "led", np.random.default_rng(0))
    level = f * rate.sum() / rate.size
    np.testing.assert_allclose(out[rate == 0], level, rtol=1e-5)
    np.testing.assert_allclose(out[rate > 0], 1e5 + level, rtol=1e-6)
    # On the camera: pixels no streak reaches rise by that level.
    frames = {}
    for name in ("stray-light", "sim"):
        r = rigs[name]
        r.slm.show(np.full(r.slm.shape, 255, np.uint8))
        r.light.select("led")
        r.spectral_camera.set_exposure(0.01)
        frames[name] = r.spectral_camera.capture().as_float()
    light = truth(rigs["sim"]).bench.spectral_rate()
    unlit = light < 1e-3 * light.max()
    stray = f * light.sum() / light.size * 0.01 * 65435 / 30000  # ADU
    rise = np.mean(frames["stray-light"][unlit]) - np.mean(frames["sim"][unlit])
    assert rise == pytest.approx(stray, rel=0.05)


def test_speckle_is_a_static_grain_of_the_asked_contrast_under_lasers_only(rigs):
    rig = rigs["speckle"]
    contrast = nuisance_section(rig.description).speckle_contrast
    nuisance = truth(rig).bench.nuisance
    field = nuisance.speckle("laser:532")
    assert float(field.mean()) == pytest.approx(1.0, abs=0.01)
    assert float(field.std() / field.mean()) == pytest.approx(contrast, rel=0.05)
    # Correlated over a couple of pixels, independent between laser lines.
    centred = field - field.mean()
    neighbour = np.mean(centred[:, 1:] * centred[:, :-1]) / centred.var()
    far = np.mean(centred[:, 6:] * centred[:, :-6]) / centred.var()
    assert neighbour > 0.7 and abs(far) < 0.1
    other = nuisance.speckle("laser:635") - 1.0
    assert abs(np.corrcoef(centred.ravel(), other.ravel())[0, 1]) < 0.02
    rate = np.full(field.shape, 1000.0, np.float32)
    rng = np.random.default_rng(0)
    np.testing.assert_array_equal(nuisance.spectral_rate(rate, "laser:532", rng), rate * field)
    np.testing.assert_array_equal(nuisance.spectral_rate(rate, "led", rng), rate)


def test_every_nuisance_at_once_is_deterministic_from_the_seed():
    frames = []
    for _ in range(2):
        rig = open_rig(rig_file("nuisance-all"))
        rig.slm.show(pinholes(rig.slm.shape))
        rig.light.select("laser:635")
        rig.spectral_camera.set_exposure(0.02)
        frames.append(np.stack([rig.spectral_camera.capture().data for _ in range(2)]))
    np.testing.assert_array_equal(frames[0], frames[1])
    assert not np.array_equal(frames[0][0], frames[0][1])  # jitter and noise differ per frame
