"""The spectral calibration's checks and notes to the lab."""

from types import SimpleNamespace

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.calibrate.blur import fit_blur
from sassi_bench.calibrate.dispersion import LaserLine
from sassi_bench.calibrate.stated_lines import StatedLine
from sassi_bench.reduce.spectral import (
    BLUR_NOTE_ERROR,
    blur_notes,
    laser_line_checks,
    laser_line_notes,
)
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


def _lamp_less(lines, estimated=(), stated_lines=None):
    """What laser_line_notes reads of an analysed lamp-less calibration."""
    return SimpleNamespace(
        anchoring=None,
        laser_lines=lines,
        stated_lines=stated_lines or {},
        procedure={"tolerances": {"laser_line_nm": 0.5}},
        dispersion=SimpleNamespace(estimated_lines=list(estimated)),
    )


# fam10's end line as measured (docs/notes/2026-11-30-rig-family-lamps.md) and an interior
# line, each with the accuracy the others' test sheets carry to it.
FAR_END = LaserLine(402.75, 399.0, (515.91, 532.0, 636.68), False, 10.2)
INTERIOR = LaserLine(515.91, 516.14, (402.75, 532.0, 636.68), False, 0.5)


def test_an_end_line_far_from_the_others_passes_and_says_how_loosely():
    lines = {402.75: FAR_END, 515.91: INTERIOR}
    checks = {c.name: c for c in laser_line_checks(lines, 0.5)}
    assert checks["laser_line_402.75nm"].passed
    assert checks["laser_line_402.75nm"].tolerance == pytest.approx(np.hypot(0.5, 10.2))
    assert checks["laser_line_515.91nm"].tolerance == pytest.approx(np.hypot(0.5, 0.5))
    (note,) = laser_line_notes(_lamp_less(lines))
    assert note.startswith("laser 402.75 nm: checked only within 10.21 nm")
    assert "an extrapolation 113 nm beyond the nearest, 515.91 nm" in note
    assert "wavelength lamps" in note and "laser_tolerance_nm" in note


def test_a_line_its_sheet_states_says_where_the_maps_put_it_not_how_loosely_it_is_checked():
    placed = StatedLine(402.75, 0.26, 402.4, 0.02, 0.01)
    (note,) = laser_line_notes(_lamp_less({402.75: FAR_END}, [402.75], {402.75: placed}))
    assert note.startswith("laser 402.75 nm: the maps and its test sheet together place it")
    assert "402.40 +- 0.02 nm" in note and "checked only" not in note


def test_a_line_beyond_its_allowance_fails_and_names_the_fix():
    wrong = LaserLine(515.91, 518.9, (402.75, 532.0, 636.68), False, 0.5)
    (check,) = laser_line_checks({515.91: wrong}, 0.5)
    assert not check.passed and check.value == pytest.approx(2.99)
    (note,) = laser_line_notes(_lamp_less({515.91: wrong}))
    assert "beyond the 0.71 nm allowed" in note
    assert "measure the line with a spectrometer and correct lasers_nm" in note
    # A line fitted at its estimate is not checked (it agrees by construction).
    assert laser_line_checks({515.91: wrong}, 0.5, estimated=[515.91]) == []
