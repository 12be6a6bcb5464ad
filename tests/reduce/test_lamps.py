"""Where the lamp anchoring checks its laser measurements against the column model's form."""

import numpy as np
import pytest

from sassi_bench.calibrate.anchored import AnchoredWavelengths, XInformation
from sassi_bench.reduce.lamps import FORM_MISFIT_NM, LampAnchoring, described_form_misfit_nm
from sassi_bench.rig.config import load_rig_description


@pytest.mark.parametrize(
    ("rig", "measured"),
    [
        ("tests/rigs/lamps-diodes-off.yaml", 0.0013),
        ("tests/rigs/lamps-diodes-off-sf11.yaml", 0.0083),
    ],
)
def test_the_quadratic_fits_a_parametric_arm_so_its_lamp_measurements_stand(rig, measured):
    misfit = described_form_misfit_nm(load_rig_description(rig), 2)
    # measured: 0.0013 nm (N-BK7), 0.0083 nm (SF11): the lamps' measurement is taken as is
    assert misfit == pytest.approx(measured, rel=0.5)
    assert misfit < FORM_MISFIT_NM


def test_the_quadratic_misses_the_achromat_so_its_lamp_measurements_are_checked(design_rigs):
    description = design_rigs("achromat").description
    # measured: 0.085 nm RMS; a cubic 0.0047 nm
    assert described_form_misfit_nm(description, 2) > 1.5 * FORM_MISFIT_NM
    assert described_form_misfit_nm(description, 3) < 0.2 * FORM_MISFIT_NM


def _anchored(labels, wavelengths, sigma):
    return AnchoredWavelengths(
        labels_nm=np.array(labels), wavelengths_nm=np.array(wavelengths),
        sigma_nm=np.array(sigma), x_coeffs=np.zeros((3, 1)),
        information=XInformation(np.zeros((3, 3)), np.zeros(3)), lamps={},
        map_rms_px=0.0, iterations=1,
    )  # fmt: skip


def test_a_confirmed_label_carries_the_measurement_s_sigma_into_the_map():
    """Held at its label the line's fitted 1-sigma is the hold's; the map carries what the
    lamps showed: the label agrees with the measurement within the measurement's 1-sigma
    (its form shift added)."""
    measured = _anchored([488.0, 640.0], [488.01, 639.91], [0.02, 0.09])
    held = _anchored([488.0, 640.0], [488.01, 640.0], [0.019, 0.001])
    anchoring = LampAnchoring(
        fit=held, streaks=[], tables={}, exposures_s={}, frames=4, measured=measured,
        confirmed=(640.0,), form_shift_nm={640.0: 0.12},
    )  # fmt: skip
    carried = anchoring.line_sigma_by_label
    assert carried[488.0] == pytest.approx(0.019)
    assert carried[640.0] == pytest.approx(np.hypot(0.09, 0.12))
