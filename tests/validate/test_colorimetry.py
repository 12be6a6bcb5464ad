"""Colour computations against colour-science's own implementation."""

import colour
import numpy as np
import pytest

from sassi_bench.spectra.angles import spectral_angle_deg
from sassi_bench.validate.colorimetry import cube_to_srgb, delta_e2000, reflectance_to_lab
from sassi_bench.validate.reference import reference_chart


@pytest.mark.filterwarnings("ignore::colour.utilities.ColourRuntimeWarning")
def test_lab_of_the_chart_matches_colour_science():
    chart = reference_chart()
    ours = reflectance_to_lab(chart.wavelengths_nm, chart.reflectance)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    white = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    theirs = np.stack(
        [
            colour.XYZ_to_Lab(colour.sd_to_XYZ(sd, cmfs, d65) / 100.0, white)
            for sd in colour.SDS_COLOURCHECKERS["BabelColor Average"].values()
        ]
    )
    # Different integration rules (1 nm sums vs ASTM E308 tables) and different handling of
    # 730-780 nm: agreement to a small fraction of a just-noticeable difference.
    assert np.max(delta_e2000(ours, theirs)) < 0.3


def test_delta_e2000_known_pair():
    # Sharma, Wu and Dalal (2005), test pair 1.
    de = delta_e2000([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485])
    assert round(float(de), 4) == 2.0425


def test_spectral_angle_ignores_scale_and_sees_shape():
    a = np.array([0.1, 0.2, 0.4, 0.3])
    assert spectral_angle_deg(a, 3 * a) < 1e-6
    assert spectral_angle_deg(a, a[::-1]) > 10


def test_cube_to_srgb_in_blocks_matches_the_whole_cube_in_float64():
    from sassi_bench.validate import colorimetry

    rng = np.random.default_rng(3)
    lam = np.linspace(420.0, 680.0, 14)
    cube = rng.uniform(0.0, 2.0, (90, 250, lam.size)).astype(np.float32)  # several blocks
    cube[5, 7, 3] = np.nan
    usable = rng.random(cube.shape[:2]) > 0.1
    cmfs = colour.MSDS_CMFS[colorimetry.OBSERVER]
    weights = np.stack([np.interp(lam, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)])
    data = np.where(usable[..., None], np.nan_to_num(cube.astype(np.float64)), 0.0)
    xyz = data @ weights.T
    xyz /= np.percentile(xyz[..., 1], 99)
    expected = np.clip(colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=True), 0.0, 1.0)
    rgb = cube_to_srgb(lam, cube, usable=usable)
    assert rgb.dtype == np.float32 and rgb.shape == (90, 250, 3)
    np.testing.assert_allclose(rgb, expected, atol=2e-5)
    assert np.all(rgb[~usable] == 0.0)
