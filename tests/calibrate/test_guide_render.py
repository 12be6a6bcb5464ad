"""RGB renderings of cubes for the guide registration, and lattice upsampling."""

import colour
import numpy as np
import pytest

from sassi_bench.calibrate.guide_render import (
    camera_sensitivities,
    render_rgb,
    rendering_sensitivities,
    upsample_lattice,
)
from sassi_bench.errors import ConfigError


def test_camera_sensitivities_known_and_unknown():
    s = camera_sensitivities("Nikon 5100 (NPL)", np.arange(400, 701, 10.0))
    assert s.shape == (3, 31) and s.max() == pytest.approx(1.0)
    peaks = np.arange(400, 701, 10.0)[np.argmax(s, axis=1)]
    assert peaks[2] < peaks[1] < peaks[0]  # blue, green, red peaks in order
    with pytest.raises(ConfigError, match=r"guide_camera\.sensitivities"):
        camera_sensitivities("no such camera", [500.0])
    with pytest.raises(ConfigError, match="unknown camera sensitivities"):
        rendering_sensitivities("no such camera", "camera", [500.0])
    assert rendering_sensitivities("Nikon 5100 (NPL)", "cie", [500.0]) == (None, "cie")
    with pytest.raises(ValueError, match="unknown rendering"):
        rendering_sensitivities("Nikon 5100 (NPL)", "srgb", [500.0])


def test_cie_rendering_of_daylight_is_neutral_and_of_blue_light_is_blue():
    wl = np.arange(400, 701, 5.0)
    d65 = colour.SDS_ILLUMINANTS["D65"]
    spectrum = np.interp(wl, d65.wavelengths, d65.values)
    cube = np.stack([spectrum, np.where(np.abs(wl - 450) < 6, 1.0, 0.0)])[None]  # (1, 2, B)
    rgb = render_rgb(cube, wl, percentile=100)
    assert np.allclose(rgb[0, 0], rgb[0, 0].mean(), atol=0.03)  # D65 -> sRGB white
    assert rgb[0, 1, 2] > 5 * max(rgb[0, 1, 0], rgb[0, 1, 1])
    s = camera_sensitivities("Nikon 5100 (NPL)", wl)
    cam = render_rgb(cube, wl, sensitivities=s, valid=np.array([[True, False]]))
    assert cam[0, 0].max() == pytest.approx(1.0) and np.all(cam[0, 1] == 0)
    with pytest.raises(ValueError, match=r"expected \(H, W, 61\) for 61 wavelengths"):
        render_rgb(cube[..., :-1], wl)


def test_upsample_lattice_keeps_pixel_centres():
    rows, cols = np.indices((40, 64), dtype=np.float64)
    valid = np.ones((40, 16), bool)
    valid[10, 5] = False
    ramp = 0.5 * cols + rows  # bicubic reproduces a ramp: no shift of the pixel centres
    up, ok = upsample_lattice(ramp[:, ::4], valid, (4, 1), (40, 64))
    assert np.abs(up - ramp)[ok].max() < 1e-3
    assert not ok[10, 18:23].any() and ok[10, 28] and not ok[:, 61:].any()
    smooth = np.sin(cols / 20.0) + np.cos(rows / 7.0)
    up, ok = upsample_lattice(smooth[::2, ::2], np.ones((20, 32), bool), (2, 2), (40, 64))
    assert np.abs(up - smooth)[ok].max() < 0.01


@pytest.mark.parametrize("cie", [False, True])
def test_render_rgb_by_bands_of_rows_equals_the_whole_cube_projection(monkeypatch, cie):
    """The projection a band of rows at a time gives the whole float64 cube's numbers."""
    from sassi_bench.calibrate import guide_render as gr

    rng = np.random.default_rng(2)
    cube = rng.random((23, 17, 31), dtype=np.float32)
    cube[3, 4, 5], cube[7, 1, 0] = np.nan, np.inf
    valid = rng.random((23, 17)) < 0.8
    wl = np.linspace(400, 700, 31)
    weights = gr._cie_cmfs(wl) if cie else rng.random((3, 31))
    data = np.asarray(cube, dtype=np.float64)
    whole = np.where(valid[..., None] & np.isfinite(data), data, 0.0) @ weights.T
    monkeypatch.setattr(gr, "_PROJECT_VALUES", 5 * 17 * 31)  # bands of 5 rows, one short
    np.testing.assert_array_equal(gr._project(cube, valid, weights), whole)
    kwargs = {} if cie else {"sensitivities": weights}
    banded = gr.render_rgb(cube, wl, valid=valid, **kwargs)
    monkeypatch.setattr(gr, "_PROJECT_VALUES", 1 << 30)  # one band
    np.testing.assert_array_equal(banded, gr.render_rgb(cube, wl, valid=valid, **kwargs))
