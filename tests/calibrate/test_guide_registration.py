"""Guide registration functions: SIFT homography, refinement, quality and failures."""

import cv2
import numpy as np
import pytest
from skimage import data as skdata

from sassi_bench.calibrate.guide_registration import (
    RegistrationError,
    apply_homography,
    field_discrepancy_px,
    register_guide,
)

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


def test_register_recovers_a_projective_map(slm_photo):
    guide = _guide_view(slm_photo, noise=2.0)
    sparse = register_guide(guide, slm_photo, dense=False)
    dense = register_guide(guide, slm_photo)
    q = dense.quality
    assert q.inliers >= 100 and q.inlier_ratio > 0.5 and q.coverage > 0.5
    assert q.rms_px < 1.0 and q.dense_correlation > 0.9
    # Against the true map, SLM px RMS over the field (measured value beside each bound).
    assert field_discrepancy_px(sparse.homography, H_TRUE, SLM_SHAPE)[0] < 0.10  # measured 0.052
    rms, worst = field_discrepancy_px(dense.homography, H_TRUE, SLM_SHAPE)
    assert rms < 0.014 and worst < 0.045  # measured 0.0073 and 0.023
    # The inliers are where the homography sends them.
    moved = apply_homography(dense.homography, dense.guide_points[dense.inlier])
    assert np.sqrt(np.mean(np.sum((moved - dense.slm_points[dense.inlier]) ** 2, 1))) == (
        pytest.approx(q.rms_px)
    )
    ransac = register_guide(guide, slm_photo, method="ransac", dense=False)
    assert field_discrepancy_px(ransac.homography, H_TRUE, SLM_SHAPE)[0] < 0.10  # measured 0.052
    assert "ECC" in dense.info()["method"] and "ECC" not in sparse.info()["method"]


def test_register_respects_the_slm_mask(slm_photo):
    valid = np.ones(SLM_SHAPE, bool)
    valid[:, 300:] = False
    damaged = slm_photo.copy()
    damaged[:, 300:] = 255.0  # garbage where nothing was measured
    reg = register_guide(_guide_view(slm_photo, noise=2.0), damaged, slm_valid=valid)
    assert reg.slm_points[:, 0].max() < 300
    assert field_discrepancy_px(reg.homography, H_TRUE, SLM_SHAPE)[0] < 0.065  # measured 0.035


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
