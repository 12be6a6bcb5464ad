"""The moving scene: a pose per frame, seen alike by both cameras and by the truth."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.rig.sim import truth
from sassi_bench.rig.sim.scenes import ScenePose, posed_scene


@pytest.fixture(scope="module")
def rig():
    rig = open_rig("sim")
    rig.light.select("led")
    return rig


def test_translation_moves_the_truth_cube_by_whole_pixels(rig):
    t = truth(rig)
    still, _ = t.scene_cube("colorchecker")
    moved, _ = t.scene_cube("colorchecker", ScenePose((3.0, -2.0)))
    # Content at static (row, col) appears at (row - 2, col + 3); compare the overlap.
    assert np.allclose(moved[10:-10, 13:-10], still[12:-8, 10:-13], atol=1e-6)
    assert not np.allclose(moved, still)


def test_rotation_turns_about_the_slm_centre(rig):
    t = truth(rig)
    still, _ = t.scene_cube("pcb")
    turned, _ = t.scene_cube("pcb", ScenePose(rotation_deg=2.0))
    h, w = still.shape[:2]
    centre = (h // 2 - 5, w // 2 - 5)
    rows, cols = slice(centre[0], centre[0] + 10), slice(centre[1], centre[1] + 10)
    # Near the centre a 2 degree turn moves pixels by well under one pixel; far away not.
    assert np.mean(turned[rows, cols] == still[rows, cols]) > 0.8
    assert np.mean(turned[:40, :40] == still[:40, :40]) < 0.99


def test_both_cameras_see_the_posed_scene(rig):
    pattern = np.zeros(rig.slm.shape, bool)
    pattern[::5, ::100] = True
    rig.slm.show(pattern)
    views = []
    for pose in (None, None, ScenePose((4.0, 1.0), 1.0)):
        rig.set_scene("pcb", pose)
        views.append([rig.guide_camera.capture().data, rig.spectral_camera.capture().data])
        assert np.array_equal(truth(rig).scene_cube()[0], truth(rig).scene_cube("pcb", pose)[0])
    for camera in (0, 1):
        still, again, moved = (v[camera].astype(float) for v in views)
        # Moving the scene changes each camera's frame far beyond its noise.
        assert np.mean(np.abs(moved - still)) > 2 * np.mean(np.abs(again - still))


def test_static_pose_is_todays_scene(rig):
    bench = truth(rig).bench
    scene = bench.scene_named("colorchecker")
    assert posed_scene(scene, ScenePose(), bench.slm_shape) is scene
    rig.set_scene("colorchecker")
    assert bench.scene is scene and bench.pose.is_identity


def test_basis_scenes_move_their_coefficients():
    from sassi_bench.rig.sim.scenes import BasisScene

    rng = np.random.default_rng(1)
    coefficients = rng.random((2, 20, 30)).astype(np.float32)
    scene = BasisScene("b", np.array([400.0, 700.0]), 5, coefficients=coefficients, basis=np.eye(2))
    moved = posed_scene(scene, ScenePose((2.0, 1.0)), (10, 20))
    assert np.allclose(moved.coefficients[:, 6:-3, 7:-3], coefficients[:, 5:-4, 5:-5])
