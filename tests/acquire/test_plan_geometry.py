"""Plans from the rig's nominal optics: every spacing derived at plan time, YAML values
overrides, a plan that cannot fit refused naming the optical change that fixes it."""

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from sassi_bench.acquire.plan_geometry import (
    FIELD_MISFIT_PX,
    ORDER_MISFIT_PX,
    dispersion_order,
    field_degree,
    guide_stride,
    plan_geometry,
    planned_guide,
    planned_health_check,
    planned_macbeth,
    planned_spectral,
    scan_pitch,
)
from sassi_bench.acquire.scan_plans import check_stride
from sassi_bench.acquire.spectral_plans import check_lamp_pitch
from sassi_bench.acquire.streak_pitch import (
    check_scan_pitch,
    described_spot_sigma,
    scan_pitch_room,
)
from sassi_bench.errors import ConfigError, ProcedureError
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim.family import family_rigs

RIGS = Path(__file__).resolve().parents[1] / "rigs"


def _rig(**changes) -> dict:
    """The SF10 80 px test rig (lamps added) with some sections changed."""
    data = yaml.safe_load((RIGS / "prism-sf10-80px.yaml").read_text())
    data["wavelength_lamps"] = ["HgAr", "Ne"]
    for key, value in changes.items():
        section, name = key.split("__")
        data[section][name] = value
    return data


def test_sim_derives_the_spacings_it_was_calibrated_with():
    geo = plan_geometry(load_rig_description("sim"))
    # The Nyquist scan, the sweep's period and Gray block and the guide's inlier count
    # of the shipped procedures before they were derived.
    assert geo.scan_pitch == (100, 5)
    assert (geo.phase_period, geo.gray_block, geo.min_inliers) == (16, 8, 30)
    desc = load_rig_description("sim")
    check_lamp_pitch(desc, planned_spectral(load_procedure("spectral_calibration"), desc))


@pytest.mark.parametrize("spread", [60, 80, 110, 140])
def test_derived_pitches_are_the_smallest_that_keep_the_streaks_apart(spread):
    desc = rig_description_from_dict(_rig(prism__spread_px=spread, spectral_camera__width=1000))
    geo = plan_geometry(desc)
    check_scan_pitch(desc, geo.scan_pitch)
    assert geo.scan_pitch[0] % 4 == 0  # the guide's stride divides it
    assert geo.scan_pitch[0] - scan_pitch_room(desc, 100).needed_pitch < 4
    with pytest.raises(ProcedureError):
        check_scan_pitch(desc, (scan_pitch_room(desc, 100).needed_pitch - 1, 5))
    lamps = {"lamps": {"pinhole_pitch_px": list(geo.lamp_pitch)}}
    check_lamp_pitch(desc, lamps)
    lamps["lamps"]["pinhole_pitch_px"][0] -= 1
    with pytest.raises(ConfigError, match=r"lamp frames: .*Fix: set lamps.pinhole_pitch_px"):
        check_lamp_pitch(desc, lamps)
    # A longer streak needs a longer pitch.
    assert geo.scan_pitch[0] > spread


def test_a_spot_wide_over_most_of_the_band_spaces_the_scan_rows_further():
    """Stacked rows are 1.5 widest sigmas apart when the spot is wide only at the band's
    ends, and 2.25 of the band's median sigma apart when it is wide over most of it."""
    ends = {400: 3.0, 450: 0.9, 550: 0.7, 650: 0.9, 700: 3.0}
    wide = {400: 3.0, 450: 2.7, 550: 2.6, 650: 2.7, 700: 3.0}
    at_ends = plan_geometry(rig_description_from_dict(_rig(blur__sigma_px=ends)))
    desc = rig_description_from_dict(_rig(blur__sigma_px=wide))
    geo = plan_geometry(desc)
    assert at_ends.spot_sigma_px[1] == pytest.approx(geo.spot_sigma_px[1], rel=0.02)
    rows = at_ends.rows_per_slm_px
    assert at_ends.scan_pitch[1] == math.ceil(1.5 * at_ends.spot_sigma_px[1] / rows)
    median = float(np.median(described_spot_sigma(desc, np.linspace(400, 700, 31))))
    assert geo.scan_pitch[1] == math.ceil(2.25 * median / geo.rows_per_slm_px)
    assert geo.scan_pitch[1] > at_ends.scan_pitch[1]
    assert geo.scan_pitch[0] == at_ends.scan_pitch[0]


def test_the_design_rigs_rows_follow_their_spots_over_the_band():
    # The singlet's spot is 3.3 SLM rows wide at the band's median (focused in the blue),
    # the achromat's 2.1; the parametric rigs' 1.0-1.3 keep the widest-sigma rule.
    assert plan_geometry(load_rig_description("sim-singlet")).scan_pitch[1] == 8
    assert plan_geometry(load_rig_description("sim-achromat")).scan_pitch[1] == 5
    assert plan_geometry(load_rig_description("sim-prototype")).scan_pitch[1] == 6


def test_the_spectral_procedure_gets_derived_values_and_keeps_overrides():
    desc = load_rig_description(str(RIGS / "lamps-diodes-off-sf11.yaml"))
    geo = plan_geometry(desc)
    derived = planned_spectral(load_procedure("spectral_calibration"), desc)
    assert derived["lamps"]["pinhole_pitch_px"] == list(geo.lamp_pitch)
    assert derived["blur"]["pinhole_pitch_px"] == list(geo.blur_pitch)
    assert derived["sweep"]["phase_period_px"] == geo.phase_period
    assert derived["sweep"]["gray_block_px"] == geo.phase_period // 2
    given = load_procedure("spectral_calibration")
    given["blur"]["pinhole_pitch_px"] = [40, 40]
    given["sweep"]["phase_period_px"] = 24
    kept = planned_spectral(given, desc)
    assert kept["blur"]["pinhole_pitch_px"] == [40, 40]
    assert (kept["sweep"]["phase_period_px"], kept["sweep"]["gray_block_px"]) == (24, 12)
    assert given["lamps"]["pinhole_pitch_px"] is None  # the procedure passed is not changed


def _field_misfit_px(desc, degree: int) -> float:
    """Largest camera distance between the described optics' streak positions and their
    field series of ``degree``, over a 25 x 15 field grid at 400, 550 and 700 nm."""
    h, w = desc.slm.height, desc.slm.width
    v, u = np.meshgrid(np.linspace(0, h - 1, 15), np.linspace(0, w - 1, 25))
    u, v = u.ravel(), v.ravel()
    x, y = desc.nominal_relay().forward(u[:, None], v[:, None], np.array([[400.0, 550.0, 700.0]]))
    design = legendre2d_design(*field_coordinates(u, v, (h, w)), degree)
    values = np.concatenate([x, y], axis=1)
    coeffs, *_ = np.linalg.lstsq(design, values, rcond=None)
    return float(np.abs(values - design @ coeffs).max())


def test_the_fits_field_degree_follows_the_described_optics_over_the_field():
    # A 1280 x 720 SLM imaged off-axis, rotated 1.4 deg, with barrel distortion (the
    # family's fam05): a degree-5 series leaves its map a pixel off at the corners.
    wide = rig_description_from_dict(family_rigs(45, 6)[5])
    degree = field_degree(wide)
    assert degree > 5
    assert _field_misfit_px(wide, degree) <= FIELD_MISFIT_PX
    assert _field_misfit_px(wide, degree - 1) > FIELD_MISFIT_PX
    assert (
        planned_spectral(load_procedure("spectral_calibration"), wide)["fit"]["field_degree"]
        == degree
    )
    # The rigs the procedures were tuned on keep 5; a number in the procedure stays.
    for name in ("sim", "sim-singlet", str(RIGS / "prism-sf10.yaml")):
        assert field_degree(load_rig_description(name)) == 5, name
    given = load_procedure("spectral_calibration")
    given["fit"]["field_degree"] = 6
    assert planned_spectral(given, wide)["fit"]["field_degree"] == 6


def _order_misfit_px(desc, order: int) -> float:
    """How far the streaks' columns of the described optics are from a polynomial of
    ``order`` in the glass index, the worst over the field (camera px)."""
    from sassi_bench.optics.glass import get_glass

    h, w = desc.slm.height, desc.slm.width
    v, u = np.mgrid[0 : h : (h - 1) / 12, 0 : w : (w - 1) / 20].reshape(2, -1)
    lam = np.linspace(400.0, 700.0, 41)
    x, _ = desc.nominal_relay().forward(u[:, None], v[:, None], lam[None, :])
    index = get_glass(desc.prism.glass).index(lam)
    powers = ((index - index.mean()) / np.ptp(index))[:, None] ** np.arange(order + 1)
    coeffs, *_ = np.linalg.lstsq(powers, x.T, rcond=None)
    return float(np.abs(x.T - powers @ coeffs).max())


def test_the_fits_dispersion_order_follows_the_described_optics():
    # A 1920 x 1080 SLM imaged 320 camera px off the axis through an SF10 prism, with
    # lamps (the family's fam19): a quadratic in the glass index misses its streaks'
    # columns at the field's edge by more than the bundle places them to.
    wide = family_rigs(45, 20)[19]
    desc = rig_description_from_dict(wide)
    assert _order_misfit_px(desc, 2) > ORDER_MISFIT_PX
    assert _order_misfit_px(desc, 3) < ORDER_MISFIT_PX / 10
    assert dispersion_order(desc) == 3
    planned = planned_spectral(load_procedure("spectral_calibration"), desc)
    assert planned["fit"]["dispersion_order"] == 3
    # Without lamps its five lasers cannot spare a line for the extra power.
    bare = rig_description_from_dict({k: v for k, v in wide.items() if k != "wavelength_lamps"})
    assert len(bare.lasers_nm) < 6 and dispersion_order(bare) == 2
    # The rigs the procedures were tuned on keep the quadratic, the achromat arm too (its
    # form misfit is carried by the lamp measurement's uncertainty instead).
    for name in ("sim", "sim-prototype", "sim-achromat", str(RIGS / "prism-sf10.yaml")):
        assert dispersion_order(load_rig_description(name)) == 2, name
    given = load_procedure("spectral_calibration")
    given["fit"]["dispersion_order"] = 2
    assert planned_spectral(given, desc)["fit"]["dispersion_order"] == 2
    # Six lasers from 473 to 633 nm on an N-SF11 bench (the family's fam00): its rows
    # miss a quadratic in wavelength by more than a tenth of a pixel, its columns fit a
    # quadratic in the index; a cubic through those lines would reach past them to 400
    # and 700 nm, so the quadratic stays.
    six = rig_description_from_dict(family_rigs(45, 20)[0])
    assert len(six.lasers_nm) >= 6 and _order_misfit_px(six, 2) < ORDER_MISFIT_PX
    assert dispersion_order(six) == 2


def test_an_override_below_the_derived_lamp_pitch_names_both():
    desc = load_rig_description("sim")
    needed = plan_geometry(desc).lamp_pitch[0]
    with pytest.raises(ConfigError) as caught:
        check_lamp_pitch(desc, {"lamps": {"pinhole_pitch_px": [60, 24]}})
    assert f"at least [{needed}, 24]" in str(caught.value) and "null" in str(caught.value)


def test_guide_macbeth_and_health_check_plans():
    desc = rig_description_from_dict(_rig(prism__spread_px=110, spectral_camera__width=1000))
    geo = plan_geometry(desc)
    guide = planned_guide(load_procedure("guide_registration"), desc)
    assert guide["scan"]["pitch_px"] == list(geo.scan_pitch)
    check_stride(guide["scan"]["pitch_px"], guide["scan"]["stride_px"])
    # A stride of 3 gets a pitch it divides, never shorter than the streaks need.
    three = load_procedure("guide_registration")
    three["scan"]["stride_px"] = [3, 1]
    pitch = planned_guide(three, desc)["scan"]["pitch_px"]
    assert pitch[0] % 3 == 0 and pitch[0] >= scan_pitch_room(desc, 100).needed_pitch
    assert planned_macbeth(load_procedure("macbeth_validation"), desc)["scan"]["pitch_px"] == (
        list(geo.scan_pitch)
    )
    health = planned_health_check(load_procedure("health_check"), desc)
    assert health["pinhole_pitch_px"] == list(geo.lamp_pitch)
    assert scan_pitch(desc, [200, 7]) == (200, 7)


def test_a_smaller_slm_asks_fewer_guide_inliers():
    small = rig_description_from_dict(
        _rig(slm__width=320, slm__height=240, guide_camera__width=300, guide_camera__height=240)
    )
    # 30 on 640 x 400; a 320 x 240 field shows 0.3 of that texture: 9, at least 12.
    assert plan_geometry(small).min_inliers == 12
    assert plan_geometry(load_rig_description("sim")).min_inliers == 30


def test_a_narrower_slm_gets_a_finer_guide_scan_lattice():
    """The guide scan's derived stride: 4 on 640 px wide, in proportion below, never 0;
    a procedure's own stride stays and the derived pitch is a multiple of either."""
    for width, stride in {640: 4, 480: 3, 320: 2, 200: 1}.items():
        desc = rig_description_from_dict(_rig(slm__width=width))
        assert guide_stride(desc) == (stride, 1), width
    assert guide_stride(load_rig_description("sim-prototype")) == (4, 1)  # 1920 px wide
    small = rig_description_from_dict(
        _rig(slm__width=320, slm__height=240, guide_camera__width=300, guide_camera__height=240)
    )
    planned = planned_guide(load_procedure("guide_registration"), small)["scan"]
    assert planned["stride_px"] == [2, 1]
    check_stride(planned["pitch_px"], planned["stride_px"])
    given = load_procedure("guide_registration")
    given["scan"]["stride_px"] = [4, 1]
    assert planned_guide(given, small)["scan"]["stride_px"] == [4, 1]


def test_a_streak_too_long_for_the_slm_is_refused_naming_the_optics():
    data = _rig(prism__spread_px=140, slm__width=160, spectral_camera__width=700)
    data["guide_camera"]["width"] = 200
    desc = rig_description_from_dict(data)
    with pytest.raises(ProcedureError) as caught:
        plan_geometry(desc)
    message = str(caught.value)
    assert message.startswith("pinhole scan: one streak with its blur spans")
    assert "160 px wide SLM" in message and "prism that disperses less" in message
