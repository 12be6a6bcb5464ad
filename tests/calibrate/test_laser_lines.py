"""A laser whose true line is off its label is found, named and estimated by the others."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.calibrate.dispersion import check_laser_lines, fit_dispersion
from sassi_bench.rig.sim import truth

RIGS = "tests/rigs/"


def _rms(error) -> float:
    return float(np.sqrt(np.mean(np.square(error))))


@pytest.fixture(scope="module")
def laser_rig():
    """The sim rig whose 635 nm laser really emits at 637.8 nm."""
    return open_rig(RIGS + "as-built-laser.yaml")


def test_lines_on_their_labels_agree(sim_rig, true_laser_maps):
    labels = list(sim_rig.description.lasers_nm)
    lines = check_laser_lines(true_laser_maps(sim_rig, labels), "N-BK7", sim_rig.slm.shape, 0.5)
    assert not any(line.off_label for line in lines.values())
    assert max(abs(line.offset_nm) for line in lines.values()) < 0.0065  # measured 0.0032


def test_the_line_off_its_label_is_named_and_estimated(laser_rig, true_laser_maps):
    labels = list(laser_rig.description.lasers_nm)
    maps = true_laser_maps(laser_rig, labels)
    lines = check_laser_lines(maps, "N-BK7", laser_rig.slm.shape, 0.5)
    assert [label for label, line in lines.items() if line.off_label] == [635.0]
    # The target is 0.3 nm; measured 0.0008 nm.
    assert lines[635.0].estimated_nm == pytest.approx(
        truth(laser_rig).laser_centre_nm(635), abs=0.0016
    )
    assert 635.0 not in lines[635.0].from_lines
    # The others, judged without the culprit, sit on their labels.
    assert all(abs(lines[k].offset_nm) < 0.014 for k in labels if k != 635.0)  # measured 0.0071

    at_labels = fit_dispersion(maps, "N-BK7", laser_rig.slm.shape)
    bench = truth(laser_rig)
    assert _rms(bench.wavelength_map_error_nm(at_labels.model)) > 0.5  # the label spoils it
    estimated = fit_dispersion(
        maps, "N-BK7", laser_rig.slm.shape, wavelengths_nm={635.0: lines[635.0].estimated_nm}
    )
    assert estimated.estimated_lines == [635.0]
    assert estimated.wavelengths_nm[635.0] == lines[635.0].estimated_nm
    assert _rms(bench.wavelength_map_error_nm(estimated.model)) < 0.0022  # measured 0.0011 nm
    assert estimated.leave_one_out_rms_nm < 0.0008  # measured 0.00039 nm


def test_four_lines_cannot_tell_which_one_is_off(laser_rig, true_laser_maps):
    labels = [450.0, 520.0, 635.0, 670.0]
    lines = check_laser_lines(true_laser_maps(laser_rig, labels), "N-BK7", laser_rig.slm.shape, 0.5)
    assert not any(line.off_label for line in lines.values())
    assert abs(lines[635.0].offset_nm) > 0.5  # still flagged beyond the tolerance
