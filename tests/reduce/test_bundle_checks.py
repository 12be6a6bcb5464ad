"""The map's stated 1-sigma against what the bundle is graded to, and what the lamp-line
note says when a lamp line sits many sigmas off the map."""

from types import SimpleNamespace

from sassi_bench.bundle import QualityCheck
from sassi_bench.reduce.bundle_checks import bundle_check_notes, measured_bundle_checks


def _map(worst_px: float, rms_px: float, worst_nm: float, rms_nm: float):
    return SimpleNamespace(
        position_sigma_px=worst_px,
        position_sigma_rms_px=rms_px,
        position_sigma_nm=worst_nm,
        position_sigma_rms_nm=rms_nm,
    )


def test_the_map_sigma_is_graded_by_its_rms_over_the_band_against_the_target():
    # Lasers from 403 to 637 nm: the 1-sigma at 700 nm is large, the band's RMS within
    # the 0.3 nm the bundle is graded to (a right bundle of the rig family); lines from
    # 473 nm: the column's 1-sigma at 400 nm, where the dispersion is steepest, above
    # 0.1 px, its RMS within.
    short = {c.name: c for c in measured_bundle_checks(_map(0.13, 0.05, 0.41, 0.17), None, {})}
    assert short["map_sigma_nm"].passed and short["map_sigma_px"].passed
    assert short["map_sigma_nm"].value == 0.17
    wide = _map(0.3, 0.12, 0.9, 0.35)
    checks = measured_bundle_checks(wide, None, {})
    assert not any(c.passed for c in checks if c.name.startswith("map_sigma"))
    (note,) = bundle_check_notes(checks, wide, None, "SF10")
    assert "+-0.120 px (+-0.350 nm) RMS over the band" in note
    assert "band's ends" in note and "wavelength_lamps" in note
    # A procedure's own tolerance still rules.
    strict = measured_bundle_checks(_map(0.13, 0.05, 0.41, 0.17), None, {"map_sigma_nm": 0.15})
    assert not {c.name: c for c in strict}["map_sigma_nm"].passed


def _fam07_before(chi2):
    """fam07's anchoring before the stiff start: HgAr 407.8 nm taken for 404.7 nm."""
    residuals = {"HgAr": {407.7837: (-0.700, 0.020)}, "Ne": {616.3594: (0.0, 0.01)}}
    return SimpleNamespace(
        form_misfit_nm=0.0,
        line_residuals_nm=lambda: residuals,
        fit=SimpleNamespace(lamps={k: SimpleNamespace(chi2=v) for k, v in chi2.items()}),
    )


def test_the_lamp_line_note_gives_each_lamps_fit_so_a_misidentified_lamp_shows():
    failed = [QualityCheck.at_most("lamp_line_max_sigmas", 34.5, 5.0, "1")]
    (note,) = bundle_check_notes(failed, None, _fam07_before({"HgAr": 78.9, "Ne": 2.3}), "N-SF11")
    assert "lamp line HgAr 407.8 nm: -0.700 nm" in note
    assert "reduced chi-squares of HgAr 78.9, Ne 2.3" in note
    assert "taken for their neighbours" in note and "laser_tolerance_nm" in note


def test_a_single_lamp_has_no_other_to_compare_its_fit_with():
    failed = [QualityCheck.at_most("lamp_line_max_sigmas", 34.5, 5.0, "1")]
    anchoring = _fam07_before({"HgAr": 78.9})
    anchoring.line_residuals_nm = lambda: {"HgAr": {407.7837: (-0.700, 0.020)}}
    (note,) = bundle_check_notes(failed, None, anchoring, "N-SF11")
    assert "chi-square" not in note and "prism's glass may not be" in note
