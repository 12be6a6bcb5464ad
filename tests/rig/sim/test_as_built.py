"""The virtual bench renders its as-built values, and its truth follows them."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.errors import ConfigError
from sassi_bench.optics.datasets import camera_sensitivities
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim import as_built, truth

RIGS = "tests/rigs/"


@pytest.fixture(scope="module")
def all_rig():
    return open_rig(RIGS + "as-built-all.yaml")


def test_a_rig_without_as_built_is_rendered_as_described(sim_rig):
    t = truth(sim_rig)
    assert t.laser_centre_nm(635) == 635.0 and t.halogen_k == 3000.0
    x, _ = t.slm_to_camera([319.5, 319.5], [199.5, 199.5], [400.0, 700.0])
    assert x[1] - x[0] == pytest.approx(68.0, abs=1e-6)  # prism.spread_px


def test_the_bench_renders_the_true_values(all_rig, sim_rig):
    t, nominal = truth(all_rig), truth(sim_rig)
    laser = t.light_samples("laser:635")
    centre = np.average(laser.wavelengths_nm, weights=laser.weights)
    assert centre == pytest.approx(637.8, abs=0.01)
    assert t.light_samples("laser:532").wavelengths_nm.mean() == pytest.approx(532.0)
    # Another melt and apex: the streak is no longer the described 68 px.
    x, _ = t.slm_to_camera([319.5, 319.5], [199.5, 199.5], [400.0, 700.0])
    assert abs((x[1] - x[0]) - 68.0) > 0.5
    # The hotter lamp is bluer; the LED and the guide sensor are the true ones.
    grid = t.wavelengths_nm
    halogen = t.light_samples("halogen").weights / nominal.light_samples("halogen").weights
    assert halogen[grid < 450].mean() > halogen[grid > 650].mean() * 1.05
    assert not np.allclose(t.light_samples("led").weights, nominal.light_samples("led").weights)
    assert np.allclose(t.guide_sensitivities, camera_sensitivities("Sigma SDMerill (NPL)", grid))
    # The SLM's grey levels follow its true gamma.
    g = np.array([128], np.uint8)
    eps = t.contrast_eps
    assert t.bench.transmission(g)[0] == pytest.approx(eps + (1 - eps) * (128 / 255) ** 2.5)


def test_procedures_see_the_nominal_description_only(all_rig, sim_rig):
    desc = all_rig.description
    assert desc.lasers_nm == sim_rig.description.lasers_nm
    assert "as_built" not in desc.to_dict()
    nominal = load_rig_description("sim").to_dict()
    nominal["name"] = desc.name
    nominal["description"] = desc.description
    nominal.pop("wavelength_lamps")  # the as-built rigs have no lamps
    assert desc.sha256() == rig_description_from_dict(nominal).sha256()


def test_guide_sensitivities_from_a_csv(tmp_path):
    grid = np.arange(400.0, 701.0, 10.0)
    curves = np.stack([np.exp(-(((grid - c) / 40.0) ** 2)) for c in (610, 540, 460)])
    csv = tmp_path / "guide.csv"
    rows = "\n".join(",".join(f"{v:g}" for v in row) for row in np.column_stack([grid, curves.T]))
    csv.write_text("wavelength_nm,r,g,b\n" + rows + "\n")
    data = load_rig_description("sim").to_dict()
    data["as_built"] = {"guide_sensitivities": "guide.csv"}
    (tmp_path / "rig.yaml").write_text("")  # the CSV is found next to the rig file
    desc = rig_description_from_dict(data, source=str(tmp_path / "rig.yaml"))
    assert np.allclose(as_built.guide_sensitivities(desc, grid), curves / curves.max())
    csv.write_text("wavelength_nm,r,g,b\n400,1,2\n")
    with pytest.raises(ConfigError, match=r"as_built\.guide_sensitivities: .* four columns"):
        as_built.guide_sensitivities(desc, grid)


def test_the_bench_renders_the_stated_values_as_built():
    """Every value a lab states from a datasheet or drawing can be built otherwise
    (``tests/rigs/as-built-optics.yaml``); the description procedures read is unchanged."""
    built = open_rig(RIGS + "as-built-optics.yaml")
    described = open_rig("sim")
    t, nominal = truth(built), truth(described)
    assert built.description.relay.scale == described.description.relay.scale == 1.08
    # The relay's scale 1.09: the SLM's image 1.09 / 1.08 as wide, the streak as long.
    u, v = [0.0, 639.0], [199.5, 199.5]
    x, _ = t.slm_to_camera(u, v, [550.0, 550.0])
    x0, _ = nominal.slm_to_camera(u, v, [550.0, 550.0])
    assert (x[1] - x[0]) / (x0[1] - x0[0]) == pytest.approx(1.09 / 1.08, rel=2e-3)
    ends, _ = t.slm_to_camera([319.5, 319.5], [199.5, 199.5], [400.0, 700.0])
    assert ends[1] - ends[0] == pytest.approx(68.0, abs=0.5)
    # The PSF 10 % wider, the SLM pixel's aperture 0.91 of its pitch, the contrast 800.
    assert t.blur_sigma_px(650.0) == pytest.approx(1.1 * nominal.blur_sigma_px(650.0))
    spot = np.sqrt(t.blur_sigma_px(650.0) ** 2 + ((0.91 * 1.09) ** 2 + 1) / 12)
    assert float(t.line_spread_sigma_px(650.0)) == pytest.approx(float(spot), rel=1e-6)
    assert t.contrast_eps == pytest.approx(1 / 800)
    # The camera: read noise, gain and full well as built.
    sensor = t.bench.sensor
    assert (sensor.read_noise_e, sensor.gain_e_per_adu, sensor.full_well_e) == (5.5, 0.47, 29000)
    width = t.light_samples("laser:532")
    spread = np.sqrt(np.average((width.wavelengths_nm - 532.0) ** 2, weights=width.weights))
    narrow = nominal.light_samples("laser:532")
    spread0 = np.sqrt(np.average((narrow.wavelengths_nm - 532.0) ** 2, weights=narrow.weights))
    assert spread / spread0 == pytest.approx(1.3, rel=0.05)
