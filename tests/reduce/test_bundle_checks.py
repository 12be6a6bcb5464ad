"""What the lamp-line note says when a lamp line sits many sigmas off the map."""

from types import SimpleNamespace

from sassi_bench.bundle import QualityCheck
from sassi_bench.reduce.bundle_checks import bundle_check_notes


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
