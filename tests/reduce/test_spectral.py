"""The spectral calibration's notes to the lab."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.calibrate.blur import fit_blur
from sassi_bench.reduce.spectral import BLUR_NOTE_ERROR, blur_notes
from sassi_bench.rig.sim import truth

LASERS_NM = np.array([450.0, 520.0, 532.0, 635.0, 670.0])


@pytest.mark.parametrize(
    ("rig_name", "noted"), [("sim", False), ("tests/rigs/prism-sf10.yaml", True)]
)
def test_a_blur_curve_no_quadratic_follows_is_noted_with_where_to_add_a_line(rig_name, noted):
    """The bench's own spot widths at its lasers: sim's PSF is a quadratic (its fit
    states 0.56 %), the SF10 rig's four-point curve is not (11.5 %, 8 % off between its
    lasers)."""
    rig = open_rig(rig_name)
    desc = rig.description
    widths = truth(rig).line_spread_sigma_px(LASERS_NM)
    fit = fit_blur(LASERS_NM, widths, aperture_px=desc.slm.fill_factor * desc.relay.scale)
    notes = blur_notes(fit)
    assert bool(notes) == noted
    if noted:
        (note,) = notes
        assert f"{100 * fit.model.relative_error:.1f} % RMS" in note
        assert "the widest gap, 532-635 nm" in note


def test_no_blur_note_without_an_error_to_state():
    three = fit_blur(LASERS_NM[:3], [1.3, 0.8, 0.78])  # nothing to leave out
    assert three.model.relative_error is None and blur_notes(three) == []
    exact = fit_blur(LASERS_NM, 0.7 + 0.004 * (LASERS_NM - 530.0) ** 2 / 10)  # a quadratic
    assert exact.model.relative_error < 1e-9 < BLUR_NOTE_ERROR and blur_notes(exact) == []
