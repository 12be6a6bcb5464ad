"""Where the lamp anchoring checks its laser measurements against the column model's form."""

import pytest

from sassi_bench.reduce.lamps import FORM_MISFIT_NM, described_form_misfit_nm
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
