"""What the spectrum dock plots, without napari or Qt: a region's mean spectrum and its spread."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.napari.spectrum import bundle_name, provenance_text, region_spectrum

WAV = {"wav": [450.0, 550.0, 650.0]}


def _cube(rng) -> np.ndarray:
    return rng.normal(1.0, 0.2, (3, 20, 30)).astype(np.float32)  # (wavelength, y, x)


def test_a_regions_mean_and_spread_are_those_of_its_pixels():
    cube = _cube(np.random.default_rng(3))
    mask = np.zeros((20, 30), bool)
    mask[4:9, 10:22] = True
    mask[15, 2] = True  # a region need not be a rectangle
    spectrum = region_spectrum(cube, WAV, mask)
    pixels = cube[:, mask]  # (wavelength, 61)
    assert spectrum.pixels == 61
    np.testing.assert_allclose(spectrum.wavelengths_nm, WAV["wav"])
    np.testing.assert_allclose(spectrum.mean, pixels.mean(axis=1), rtol=1e-6)
    np.testing.assert_allclose(spectrum.std, pixels.std(axis=1), rtol=1e-5)


def test_pixels_with_no_value_are_left_out_band_by_band():
    cube = _cube(np.random.default_rng(4))
    mask = np.zeros((20, 30), bool)
    mask[0:3, 0:3] = True
    cube[1, 0, 0] = np.nan  # one pixel has no value in the middle band only
    spectrum = region_spectrum(cube, WAV, mask)
    assert spectrum.pixels == 9
    np.testing.assert_allclose(spectrum.mean[1], np.nanmean(cube[1, 0:3, 0:3]), rtol=1e-6)
    np.testing.assert_allclose(spectrum.mean[0], cube[0, 0:3, 0:3].mean(), rtol=1e-6)
    assert np.isfinite(spectrum.std).all()


def test_a_video_region_is_read_from_the_frame_shown():
    video = np.stack([np.full((3, 4, 5), t, np.float32) for t in range(4)])  # (t, wav, y, x)
    mask = np.ones((4, 5), bool)
    assert region_spectrum(video, WAV, mask, time_index=2).mean.tolist() == [2.0, 2.0, 2.0]
    assert region_spectrum(video, WAV, mask, time_index=9).mean.tolist() == [3.0, 3.0, 3.0]


def test_an_empty_region_gives_no_spectrum_and_a_wrong_sized_one_says_so():
    cube = _cube(np.random.default_rng(5))
    empty = region_spectrum(cube, WAV, np.zeros((20, 30), bool))
    assert empty.pixels == 0 and empty.mean.size == 0
    with pytest.raises(ValueError, match=r"the region is \(10, 30\) pixels, the cube \(20, 30\)"):
        region_spectrum(cube, WAV, np.ones((10, 30), bool))


def test_the_bundle_a_cube_came_from_is_named():
    metadata = {"provenance": {"bundle_rig": "sim", "bundle_version": "v0003", "scene": "x"}}
    assert bundle_name(metadata) == "sim/v0003"
    assert bundle_name({"provenance": {}}) is None
    assert provenance_text(metadata) == "bundle: sim/v0003\nscene: x"
