"""A quality check's tolerance is printed at the precision it is set, the same everywhere
it is shown: a derived 5.06134 nm reads 5.06 nm, a set 0.015 stays 0.015."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from sassi_bench.bundle import BundleError, QualityCheck
from sassi_bench.bundle.loader import _check_manifest_rules
from sassi_bench.bundle.quality import format_tolerance, normalize_quality
from sassi_bench.commands.options import print_checks
from sassi_bench.notebook.widgets import checks_table
from sassi_bench.plots.html import check_rows

DERIVED = QualityCheck.at_most("leave_one_out_rms_nm", 0.0421, 5.06134, "nm")


@pytest.mark.parametrize(
    ("tolerance", "printed"),
    [(5.06134, "5.06"), (0.5, "0.5"), (0.015, "0.015"), (30, "30"), (2500.4, "2500")],
)
def test_a_tolerance_prints_to_three_significant_digits_without_an_exponent(tolerance, printed):
    assert format_tolerance(tolerance) == printed


def test_every_place_that_shows_a_check_prints_its_tolerance_so(capsys):
    print_checks([DERIVED])
    shown = {
        "command line": capsys.readouterr().out,
        "describe": DERIVED.describe(),
        "HTML report": " ".join(check_rows([DERIVED.to_manifest()], ".3f")[0]),
        "notebook": checks_table([DERIVED]),
    }
    for where, text in shown.items():
        assert re.search(r"= 5\.06(?!\d)", text), where  # after "<" or "&lt;"


def test_a_check_that_contradicts_its_passed_flag_names_the_tolerance_so():
    wrong = {**DERIVED.to_manifest(), "value": 6.0}  # over the tolerance, yet "passed"
    with pytest.raises(BundleError, match=r"6 <= 5\.06 is False"):
        normalize_quality({"checks": [wrong], "residuals": {}})
    with pytest.raises(BundleError, match=r"6 <= 5\.06 is False"):
        _check_manifest_rules("bundle load", Path("v0001"), {"quality": {"checks": [wrong]}})
