"""Lamp line tables: the shipped ones, a lab's own CSV, and every way a table can be wrong."""

import numpy as np
import pytest

from sassi_bench.errors import ConfigError
from sassi_bench.optics.lamps import (
    ANCHOR_BAND_NM,
    lamp_name,
    lamp_samples,
    load_line_list,
    shipped_lamps,
)


def test_shipped_tables_hold_the_nist_air_wavelengths():
    hgar = load_line_list("HgAr")
    assert hgar.source == "shipped" and len(hgar.sha256) == 64
    # Current NIST ASD values (Sansonetti et al. 1996), in standard air.
    for line in (404.6565, 435.8335, 546.0750, 576.9610, 579.0670, 696.5431):
        assert np.min(np.abs(hgar.wavelengths_nm - line)) < 1e-6
    ne = load_line_list("ne")
    assert np.min(np.abs(ne.wavelengths_nm - 602.9997)) < 1e-6  # not "603.997"
    assert np.min(np.abs(ne.wavelengths_nm - 640.2248)) < 1e-6
    for lines in (hgar, ne):
        assert np.all(np.diff(lines.wavelengths_nm) > 0)
        assert lines.relative_intensity.max() == 1.0
        assert lines.wavelengths_nm.min() > 390 and lines.wavelengths_nm.max() < 710


def test_lamp_names_match_regardless_of_case_and_a_csv_is_named_by_its_stem():
    assert shipped_lamps() == ("HgAr", "Ne")
    assert lamp_name("HGAR") == "HgAr"
    assert lamp_name("benches/krypton.csv") == "krypton"
    with pytest.raises(ConfigError, match=r"unknown lamp 'Neon'.*did you mean 'Ne'.*Fix: use one"):
        lamp_name("Neon")


def test_a_lab_csv_loads_relative_to_a_folder(tmp_path):
    (tmp_path / "kr.csv").write_text(
        "# krypton, air\nwavelength_nm,relative_intensity,element\n"
        "557.0289,1.0,Kr I\n587.0915,0.8,Kr I\n431.9580,0.4,Kr I\n"
    )
    lines = load_line_list("kr.csv", base=tmp_path)
    assert lines.name == "kr" and lines.light == "lamp:kr"
    assert lines.wavelengths_nm.tolist() == [431.958, 557.0289, 587.0915]
    assert lines.elements == ("Kr I", "Kr I", "Kr I")
    assert lines.source == str(tmp_path / "kr.csv")


def test_intensities_may_be_left_out(tmp_path):
    (tmp_path / "lines.csv").write_text("wavelength_nm\n450.0\n600.0\n")
    lines = load_line_list(str(tmp_path / "lines.csv"))
    assert lines.relative_intensity.tolist() == [1.0, 1.0]


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("nm,intensity\n450,1\n600,1\n", r"has no wavelength_nm column. Fix: write '#' comment"),
        ("wavelength_nm,relative_intensity\n", r"lists no lines"),
        ("wavelength_nm,relative_intensity\n450,bright\n", r"row 2 .* is not numbers"),
        ("wavelength_nm,relative_intensity\n450,0\n600,1\n", r"not a positive number"),
        (
            "wavelength_nm,relative_intensity\n750,1\n800,1\n460,0.01\n",
            r"lamp 'bad' has 0 line\(s\) between 400 and 700 nm.*needs at least 2. Fix: use a "
            r"lamp with visible lines",
        ),
    ],
)
def test_a_bad_table_is_refused_in_one_line(tmp_path, text, pattern):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ConfigError, match=pattern) as error:
        load_line_list(str(path), step="rig description x: wavelength_lamps")
    assert "\n" not in str(error.value)
    assert str(error.value).startswith("rig description x: wavelength_lamps: ")


def test_a_missing_csv_is_named(tmp_path):
    with pytest.raises(ConfigError, match=r"no such file .*nope.csv"):
        load_line_list("nope.csv", base=tmp_path)


def test_lamp_samples_are_one_delta_per_line_carrying_the_flux_in_the_band():
    lines = load_line_list("HgAr")
    samples = lamp_samples(lines, 2e6)
    assert np.array_equal(samples.wavelengths_nm, lines.wavelengths_nm)
    inside = (samples.wavelengths_nm >= ANCHOR_BAND_NM[0]) & (
        samples.wavelengths_nm <= ANCHOR_BAND_NM[1]
    )
    assert samples.weights[inside].sum() == pytest.approx(2e6)
    ratios = samples.weights / samples.weights.max()
    assert np.allclose(ratios, lines.relative_intensity)
