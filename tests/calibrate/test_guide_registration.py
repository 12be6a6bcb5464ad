"""Guide registration functions: rendering, SIFT homography, quality and failures."""

import colour
import cv2
import numpy as np
import pytest
from skimage import data as skdata

from sassi_bench.calibrate.guide_registration import (
    RegistrationError,
    apply_homography,
    camera_sensitivities,
    field_discrepancy_px,
    register_guide,
    render_rgb,
    rendering_sensitivities,
    upsample_lattice,
)
from sassi_bench.errors import ConfigError

# A projective guide -> SLM map with rotation, scale and a little perspective.
H_TRUE = np.array([[1.12, 0.06, -20.0], [-0.05, 1.1, -14.0], [2e-5, -1e-5, 1.0]])
SLM_SHAPE = (256, 384)


@pytest.fixture(scope="module")
def slm_photo():
    return np.ascontiguousarray(
        cv2.resize(skdata.astronaut(), (SLM_SHAPE[1], SLM_SHAPE[0]), interpolation=cv2.INTER_AREA)
    ).astype(np.float32)


def _guide_view(image, h=H_TRUE, shape=(240, 360), noise=0.0, seed=0):
    """What a guide camera with homography ``h`` sees of an SLM-grid image."""
    guide = cv2.warpPerspective(
        image, h, (shape[1], shape[0]), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    )
    return guide + np.random.default_rng(seed).normal(0, noise, guide.shape)


def test_camera_sensitivities_known_and_unknown():
    s = camera_sensitivities("Nikon 5100 (NPL)", np.arange(400, 701, 10.0))
    assert s.shape == (3, 31) and s.max() == pytest.approx(1.0)
    peaks = np.arange(400, 701, 10.0)[np.argmax(s, axis=1)]
    assert peaks[2] < peaks[1] < peaks[0]  # blue, green, red peaks in order
    with pytest.raises(ConfigError, match=r"guide_camera\.sensitivities"):
        camera_sensitivities("no such camera", [500.0])
    with pytest.raises(ConfigError, match="unknown guide camera"):
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
    with pytest.raises(ValueError, match="does not match"):
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


def test_register_recovers_a_projective_map(slm_photo):
    guide = _guide_view(slm_photo, noise=2.0)
    sparse = register_guide(guide, slm_photo, dense=False)
    dense = register_guide(guide, slm_photo)
    q = dense.quality
    assert q.inliers >= 100 and q.inlier_ratio > 0.5 and q.coverage > 0.5
    assert q.rms_px < 1.0 and q.dense_correlation > 0.9
    assert field_discrepancy_px(sparse.homography, H_TRUE, SLM_SHAPE)[0] < 0.3
    rms, worst = field_discrepancy_px(dense.homography, H_TRUE, SLM_SHAPE)
    assert rms < 0.05 and worst < 0.15
    # The inliers are where the homography sends them.
    moved = apply_homography(dense.homography, dense.guide_points[dense.inlier])
    assert np.sqrt(np.mean(np.sum((moved - dense.slm_points[dense.inlier]) ** 2, 1))) == (
        pytest.approx(q.rms_px)
    )
    ransac = register_guide(guide, slm_photo, method="ransac", dense=False)
    assert field_discrepancy_px(ransac.homography, H_TRUE, SLM_SHAPE)[0] < 0.3
    assert "ECC" in dense.info()["method"] and "ECC" not in sparse.info()["method"]


def test_register_respects_the_slm_mask(slm_photo):
    valid = np.ones(SLM_SHAPE, bool)
    valid[:, 300:] = False
    damaged = slm_photo.copy()
    damaged[:, 300:] = 255.0  # garbage where nothing was measured
    reg = register_guide(_guide_view(slm_photo, noise=2.0), damaged, slm_valid=valid)
    assert reg.slm_points[:, 0].max() < 300
    assert field_discrepancy_px(reg.homography, H_TRUE, SLM_SHAPE)[0] < 0.1


def test_textureless_scene_fails_with_advice(slm_photo):
    flat = np.full((240, 360, 3), 120.0) + np.random.default_rng(1).normal(0, 1.0, (240, 360, 3))
    with pytest.raises(RegistrationError, match=r"guide registration: only \d+ SIFT matches") as e:
        register_guide(flat, slm_photo)
    assert "Fix: put a flat, well-lit, richly textured target" in str(e.value)


def test_wrong_scene_fails(slm_photo):
    other = cv2.resize(skdata.chelsea(), (360, 240)).astype(np.float32)
    with pytest.raises(RegistrationError, match=r"different scene|chance pairings"):
        register_guide(other, slm_photo)


def test_texture_in_one_corner_fails_on_coverage(slm_photo):
    guide = _guide_view(slm_photo, noise=0.5)
    corner = np.zeros(guide.shape[:2], bool)
    corner[:90, :110] = True
    guide[~corner] = 128.0
    with pytest.raises(RegistrationError, match=r"span only \d+% of the SLM field"):
        register_guide(guide, slm_photo, min_inliers=10)


def test_unknown_method_is_refused(slm_photo):
    with pytest.raises(ValueError, match="unknown method"):
        register_guide(slm_photo, slm_photo, method="lmeds")
