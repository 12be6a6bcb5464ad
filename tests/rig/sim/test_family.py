"""The rig family: seeded, spanning what labs build, and every rig of it planned from its
nominal optics (the chain on it runs in ``benchmarks/rig_family.py``)."""

import numpy as np
import pytest

from sassi_bench.acquire.plan_geometry import plan_geometry, planned_spectral
from sassi_bench.acquire.spectral_plans import check_lamp_pitch
from sassi_bench.acquire.streak_pitch import check_scan_pitch
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.config import rig_description_from_dict
from sassi_bench.rig.sim.family import GLASSES, family_rigs
from sassi_bench.rig.sim.sections import as_built_section


@pytest.fixture(scope="module")
def family():
    return family_rigs(45, 24, small=True)


def test_the_family_is_seeded(family):
    assert family_rigs(45, 2, small=True) == family[:2]
    assert family_rigs(46, 2, small=True) != family[:2]


def test_the_family_spans_what_labs_build(family):
    spreads = [r["prism"]["spread_px"] for r in family]
    assert 40 <= min(spreads) < 60 and 120 < max(spreads) <= 140
    assert len({r["prism"]["glass"] for r in family}) >= 4
    assert {r["prism"]["glass"] for r in family} <= set(GLASSES)
    assert sum("wavelength_lamps" in r for r in family) == 12
    assert all(4 <= len(r["lasers_nm"]) <= 6 for r in family)
    for rig in family:
        desc = rig_description_from_dict(rig)
        true = as_built_section(desc)
        # Built off its description by about a datasheet's tolerance in each stated value.
        assert abs(true.relay_scale / desc.relay.scale - 1) < 0.05
        assert abs(true.fill_factor - desc.slm.fill_factor) < 0.05
        assert abs(true.read_noise_e / desc.spectral_camera.read_noise_e - 1) < 0.5
        assert 0.6 < true.blur_scale < 1.4 and true.gain_e_per_adu > 0


def test_every_rig_of_the_family_gets_a_plan_its_checks_accept(family):
    procedure = load_procedure("spectral_calibration")
    for rig in family:
        desc = rig_description_from_dict(rig)
        geo = plan_geometry(desc)
        check_scan_pitch(desc, geo.scan_pitch)
        check_lamp_pitch(desc, planned_spectral(procedure, desc))
        assert geo.scan_pitch[0] <= desc.slm.width // 2, rig["name"]


def test_a_rig_without_lamps_describes_its_diodes_by_their_test_sheets(family):
    for rig in family:
        desc = rig_description_from_dict(rig)
        true = as_built_section(desc).lasers_nm  # described line -> the bench's true line
        if "wavelength_lamps" in rig:
            # With lamps the lab states the labels: diodes sit up to 5 nm off them.
            assert all(float(x).is_integer() for x in desc.lasers_nm), rig["name"]
            assert desc.laser_tolerance_nm is None
            continue
        # Without, each diode is described by its measured centre, within the sheet's
        # accuracy (a 2-sigma of 0.2-0.3 nm) of the true line; the bench keeps the truth.
        for described, line in true.items():
            accuracy = desc.laser_tolerance(described)
            assert 0.2 <= accuracy <= 0.3
            assert abs(described - line) < 2.5 * accuracy, rig["name"]
    sheets = [as_built_section(rig_description_from_dict(r)).lasers_nm for r in family]
    off = [abs(k - v) for r, sheet in zip(family, sheets, strict=True)
           if "wavelength_lamps" not in r for k, v in sheet.items()]  # fmt: skip
    assert 0.02 < np.mean(off) < 0.2  # the sheets are neither exact nor labels
