"""A lamp-less rig whose test sheet misstates a diode: the maps place the line."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.bundle import load
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.config import rig_description_from_dict
from sassi_bench.rig.sim import truth
from sassi_bench.rig.sim.family import family_rigs
from sassi_bench.workflows.spectral import run_spectral_calibration

BLUE_DIODE = 441.93  # its sheet centre, 2.8 of the sheet's sigmas off the bench's line


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    rig = open_rig(rig_description_from_dict(family_rigs(45, 21, small=True)[20]))
    data = tmp_path_factory.mktemp("sheet-rig")
    result = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=data, progress=False, session_id="s"
    )
    return rig, result, data


def test_the_bundle_records_where_the_maps_put_a_misstated_line(calibrated):
    rig, result, _ = calibrated
    bench = truth(rig)
    assert result.passed
    assert result.bundle_path is not None
    bundle = load(result.bundle_path)
    line = bundle.manifest["quality"]["laser_lines"][f"{BLUE_DIODE:g}"]
    true_line = bench.laser_centre_nm(BLUE_DIODE)
    assert abs(line["label_nm"] - true_line) > 0.35
    assert abs(line["fitted_nm"] - true_line) < 0.01  # measured 0.001 nm
    assert line["stated_sigma_nm"] == pytest.approx(0.28)
    assert line["fitted_sigma_nm"] < 0.05
    error = bench.wavelength_map_error_nm(bundle.models.dispersion)
    assert float(np.sqrt(np.mean(error**2))) < 0.05  # measured 0.011 nm (0.31 at the sheets)


def test_the_notes_say_where_the_maps_put_it(calibrated):
    _, result, _ = calibrated
    bundle = load(result.bundle_path)
    (note,) = [n for n in bundle.manifest["quality"]["notes"] if n.startswith("laser 441.93")]
    assert "the maps and its test sheet together place it at 441.54 +- 0.01 nm" in note
    assert "(-0.39 nm from the sheet's centre" in note
