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
    for chart in (babel, ohta):
        sds = colour.SDS_COLOURCHECKERS[chart.name]
        assert chart.patch_names == tuple(sds)
        for row, sd in zip(chart.reflectance, sds.values(), strict=True):
            np.testing.assert_array_equal(chart.wavelengths_nm, sd.wavelengths)
            np.testing.assert_array_equal(row, sd.values)
        # Reading order, from the reflectances themselves: white (19) brightest, black
        # (24) darkest, blue (13), green (14) and red (15) peak where their names say.
        mean = chart.reflectance.mean(axis=1)
        assert int(np.argmax(mean)) == WHITE_PATCH == 18 and int(np.argmin(mean)) == 23
        peak = chart.wavelengths_nm[np.argmax(chart.reflectance, axis=1)]
        assert peak[12] < 500 and 500 < peak[13] < 580 and peak[14] > 600
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
    edges = np.array([400.0, 433.3, 500.0, 512.5, 600.0, 700.0])
    got = chart.bin_average(edges)
    assert got.shape == (24, 5)
    # Independently: colour-science's linear interpolation on a 0.01 nm grid, box-averaged.
    for row, sd in zip(got, colour.SDS_COLOURCHECKERS["BabelColor Average"].values(), strict=True):
        fine = sd.copy().interpolate(
            colour.SpectralShape(380, 730, 0.01), interpolator=colour.LinearInterpolator
        )
        lam, val = np.asarray(fine.wavelengths), np.asarray(fine.values)
        for b in range(edges.size - 1):
            inside = (lam >= edges[b]) & (lam <= edges[b + 1])
            expected = np.trapezoid(val[inside], lam[inside]) / (lam[inside][-1] - lam[inside][0])
            assert row[b] == pytest.approx(expected, abs=2e-4)
    # Narrow bins reproduce the tabulated values at their centres.
    sd = colour.SDS_COLOURCHECKERS["BabelColor Average"]["red"]
    for lam, value in zip(sd.wavelengths[2:20], sd.values[2:20], strict=True):
        assert chart.bin_average([lam - 0.05, lam + 0.05])[14, 0] == pytest.approx(value, abs=1e-3)


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
