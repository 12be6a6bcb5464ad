"""Reference reflectances: datasets, CSV input, bin averaging."""

import colour
import numpy as np
import pytest

from sassi_bench.errors import ConfigError
from sassi_bench.validate.reference import WHITE_PATCH, read_chart_csv, reference_chart


def test_datasets_load_in_reading_order():
    babel = reference_chart()
    ohta = reference_chart("ohta")
    assert babel.name == "BabelColor Average" and ohta.name == "ColorChecker N Ohta"
    assert babel.reflectance.shape[0] == ohta.reflectance.shape[0] == 24
    assert babel.patch_names[0] == "dark skin" and "white" in babel.patch_names[WHITE_PATCH]
    # The two data sets describe the same chart: close, not identical.
    at = np.arange(400.0, 701.0, 10.0)
    diff = np.abs(
        np.stack([np.interp(at, babel.wavelengths_nm, r) for r in babel.reflectance])
        - np.stack([np.interp(at, ohta.wavelengths_nm, r) for r in ohta.reflectance])
    )
    assert 0.0 < diff.mean() < 0.02


def test_bin_average_is_the_mean_over_each_bin():
    chart = reference_chart()
    sd = colour.SDS_COLOURCHECKERS["BabelColor Average"]["red"]
    fine = np.arange(500.0, 600.01, 0.01)
    expected = np.mean(np.interp(fine, sd.wavelengths, sd.values))
    got = chart.bin_average([500.0, 600.0])[14, 0]
    assert got == pytest.approx(expected, rel=1e-4)
    # Narrow bins reproduce the tabulated values at the bin centres.
    lam = np.asarray(sd.wavelengths)
    narrow = chart.bin_average(np.r_[lam[2:20] - 0.05, lam[19] + 0.05].reshape(-1))
    assert narrow.shape[1] == 18


def test_bins_outside_the_data_are_refused():
    with pytest.raises(ConfigError, match=r"covers 380-730 nm.*Fix:"):
        reference_chart().bin_average([700.0, 750.0])


def test_unknown_data_name_says_what_to_use():
    with pytest.raises(ConfigError, match=r"BabelColor Average.*CSV"):
        reference_chart("Munsell")


def test_csv_round_trip_with_header_and_percent(tmp_path):
    chart = reference_chart()
    path = tmp_path / "mine.csv"
    rows = ["wavelength_nm," + ",".join(chart.patch_names)]
    for i, lam in enumerate(chart.wavelengths_nm):
        rows.append(",".join([f"{lam:g}"] + [f"{100 * v:.4f}" for v in chart.reflectance[:, i]]))
    path.write_text("# my chart\n" + "\n".join(rows))
    back = reference_chart(path)
    np.testing.assert_allclose(back.reflectance, chart.reflectance, atol=1e-6)
    assert back.patch_names == chart.patch_names


def test_csv_with_wrong_columns_names_the_fix(tmp_path):
    path = tmp_path / "bad.csv"
    path.write_text("400,0.1,0.2\n500,0.1,0.2\n600,0.1,0.2\n")
    with pytest.raises(ConfigError, match=r"24 reflectances.*Fix:"):
        read_chart_csv(path)
