"""A rig whose spectral arm is an optical design: the bench renders the traced design as
built; the description (what procedures see) is the design as described."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.optics.design import DesignRelay
from sassi_bench.optics.sources import SpectralSamples
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim import truth

pytestmark = pytest.mark.filterwarnings("ignore::DeprecationWarning")


@pytest.mark.parametrize("name", ["achromat", "singlet"])
def test_design_rig_describes_itself_through_its_nominal_optics(design_rigs, name):
    desc = design_rigs(name).description
    assert desc.design is not None
    data = desc.to_dict()
    assert "design" in data and not {"relay", "prism", "blur"} & set(data)
    assert rig_description_from_dict(data).sha256() == desc.sha256()
    relay = desc.nominal_relay()
    assert isinstance(relay, DesignRelay)
    # the derived parametric numbers: N-SF11 prism of 30 degrees, ~125 px from 400 to 700 nm
    assert desc.prism.glass == "N-SF11"
    assert desc.prism.apex_deg == pytest.approx(30.0, abs=1e-6)
    assert 110 < desc.prism.spread_px < 135
    assert 0.85 < desc.relay.scale < 1.0
    # shorter wavelengths land left: streaks run along +x as the calibration assumes
    x, _ = relay.forward(*relay.slm_centre, [400.0, 700.0])
    assert x[1] - x[0] == pytest.approx(desc.prism.spread_px)


def _moments(rate):
    ys, xs = np.mgrid[0 : rate.shape[0], 0 : rate.shape[1]]
    w = rate / rate.sum()
    mx, my = (w * xs).sum(), (w * ys).sum()
    return (
        mx,
        my,
        (w * (xs - mx) ** 2).sum(),
        (w * (ys - my) ** 2).sum(),
        (w * (xs - mx) * (ys - my)).sum(),
    )


@pytest.mark.parametrize("name", ["achromat", "singlet"])
@pytest.mark.parametrize(("u", "v", "lam"), [(160, 100, 550.0), (5, 4, 420.0), (314, 195, 690.0)])
def test_a_pinhole_spot_has_the_traced_centroid_and_covariance(design_rigs, name, u, v, lam):
    rig = design_rigs(name)
    bench = truth(rig).bench
    line = SpectralSamples(np.array([lam]), np.array([1.0e6]))
    rate = bench.renderer.render_sparse(
        np.array([v]), np.array([u]), np.ones(1, np.float32), bench.scene_named("white"), line
    )
    mx, my, cxx, cyy, cxy = _moments(rate.astype(np.float64))
    x, y = truth(rig).slm_to_camera(u, v, lam)
    txx, tyy, txy = truth(rig).spot_covariance(u, v, lam)
    # measured: centroids within 0.003 px, covariance within 0.5 % (4-sigma cut, per-row
    # conditional centres)
    assert mx == pytest.approx(float(x), abs=0.01)
    assert my == pytest.approx(float(y), abs=0.01)
    assert cxx == pytest.approx(float(txx), rel=0.02)
    assert cyy == pytest.approx(float(tyy), rel=0.02)
    assert cxy == pytest.approx(float(txy), abs=0.02 * float(np.sqrt(txx * tyy)))


def test_the_singlet_spot_varies_over_the_field_and_by_direction(design_rigs):
    t = truth(design_rigs("singlet"))
    u = np.array([160, 5, 314, 5])
    v = np.array([100, 4, 195, 195])
    cxx, cyy, cxy = t.spot_covariance(u, v, 650.0)
    assert cxx.max() / cxx.min() > 1.5  # grows towards the corners
    assert np.abs(cxy / np.sqrt(cxx * cyy)).max() > 0.1  # and turns


def test_as_built_moves_the_bench_but_not_the_description(tmp_path):
    pytest.importorskip("optiland", reason='pip install "sassi-bench[design]"')
    data = load_rig_description("sim-singlet").to_dict()
    nominal = load_rig_description("sim-singlet").nominal_relay()
    data["as_built"] = {"design": {"surfaces": {"7": {"decenter_mm": [0.0, 0.05]}}}}
    desc = rig_description_from_dict(data)
    assert desc.sha256() == load_rig_description("sim-singlet").sha256()
    np.testing.assert_array_equal(
        desc.nominal_relay().forward(100.0, 50.0, 550.0), nominal.forward(100.0, 50.0, 550.0)
    )
    rig = open_rig(desc)
    x, y = truth(rig).slm_to_camera(100.0, 50.0, 550.0)
    x0, y0 = nominal.forward(100.0, 50.0, 550.0)
    # a camera lens decentred by 50 um moves the image by several camera pixels
    assert abs(float(y - y0)) > 2.0
    assert abs(float(x - x0)) < 0.5 * abs(float(y - y0))


def test_a_parametric_rig_refuses_a_design_override(sim_dict):
    sim_dict["as_built"] = {"design": {"surfaces": {"1": {"thickness_mm": 1.0}}}}
    with pytest.raises(ValueError, match=r"as_built\.design"):
        open_rig(rig_description_from_dict(sim_dict))


@pytest.mark.parametrize("name", ["achromat", "singlet"])
@pytest.mark.parametrize("light", ["laser:450", "laser:670", "halogen"])
def test_a_dense_frame_blurs_runs_of_samples_within_1e_3_of_its_peak(
    design_rigs, monkeypatch, name, light
):
    from sassi_bench.acquire.patterns import render_pattern
    from sassi_bench.rig.sim import design_render

    bench = truth(design_rigs(name)).bench
    bit = {"kind": "gray", "axis": "x", "bit": 2, "block": 8, "inverse": False}
    pattern = render_pattern(bit, bench.slm_shape)
    args = (bench.slm_transmission(pattern), bench.scene_named("white"), bench.samples(light))
    gain = bench.renderer.electrons_per_photon(args[2])
    runs = bench.renderer._dense_blurs(args[2].wavelengths_nm, gain)
    assert len(runs) < np.count_nonzero(gain)  # fewer blurs than samples
    together = bench.renderer.render_dense(*args)
    monkeypatch.setattr(design_render, "BLUR_RUN_TOLERANCE", -1.0)  # a blur per sample
    assert len(bench.renderer._dense_blurs(args[2].wavelengths_nm, gain)) == np.count_nonzero(gain)
    each = bench.renderer.render_dense(*args)
    # measured up to 2.8e-4 of the peak (the singlet's 450 nm laser)
    assert np.abs(together - each).max() < 1e-3 * float(each.max())
