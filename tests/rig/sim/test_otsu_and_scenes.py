import colour
import numpy as np
import pytest

from sassi_bench.rig.sim import truth
from sassi_bench.rig.sim.otsu import OTSU2018_WAVELENGTHS_NM, xyz_to_reflectance_otsu2018
from sassi_bench.rig.sim.scenes import make_scene, natural_scene

GRID = np.arange(390.0, 721.0, 2.0)


def test_vectorised_otsu_matches_colour_science():
    rng = np.random.default_rng(7)
    xyz = rng.uniform(0.01, 0.9, size=(40, 3))
    ours = xyz_to_reflectance_otsu2018(xyz)
    reference = np.array([colour.recovery.XYZ_to_sd_Otsu2018(x).values for x in xyz])
    assert ours.shape == (40, OTSU2018_WAVELENGTHS_NM().size)
    assert np.allclose(ours, reference, atol=1e-10)


def test_otsu_handles_black_and_batches():
    out = xyz_to_reflectance_otsu2018(np.zeros((2, 3, 3)))
    assert out.shape == (2, 3, 36)
    assert np.all(np.isfinite(out))


def test_colorchecker_patches_carry_colour_science_reflectances():
    scene = make_scene("colorchecker", (400, 640), GRID, margin=8)
    labels = np.unique(scene.labels)
    assert set(range(26)) <= set(labels.tolist())
    data = colour.SDS_COLOURCHECKERS["BabelColor Average"]
    for index, name in [(0, "dark skin"), (5, "bluish green"), (18, "white 9.5 (.05 D)")]:
        sd = data[name]
        assert scene.spectra[2 + index, GRID == 550][0] == pytest.approx(sd[550], abs=1e-6)
    # Patches are laid out in reading order: dark skin top-left, black bottom-right.
    ys, xs = np.nonzero(scene.labels == 2)
    ye, xe = np.nonzero(scene.labels == 25)
    assert ys.mean() < ye.mean() and xs.mean() < xe.mean()


def test_label_and_basis_scenes_answer_consistently():
    for name in ("colorchecker", "pcb"):
        scene = make_scene(name, (60, 90), GRID, margin=5, seed=3)
        cube = scene.cube((60, 90))
        assert cube.shape == (60, 90, GRID.size)
        rows, cols = np.array([5, 20, 40]), np.array([7, 33, 80])
        spectra = scene.reflectance_at(rows + 5, cols + 5, GRID)
        assert np.allclose(spectra, cube[rows, cols], atol=1e-6)
        image = scene.reflectance_image(GRID[30])
        assert np.allclose(image[5:65, 5:95], cube[:, :, 30], atol=1e-6)


def test_natural_scene_keeps_the_otsu_spectra():
    scene = natural_scene((100, 160), GRID, margin=10, image="astronaut")
    assert scene.basis.shape == (12, GRID.size)
    cube = scene.cube((100, 160))
    # Principal-component compression keeps reflectances within 0.03 of [0, 1].
    assert cube.min() > -0.03 and cube.max() < 1.03
    # The spectra vary from pixel to pixel (a textured scene, not a flat one).
    assert cube[:, :, GRID == 550].std() > 0.05


def test_pcb_is_reproducible_from_its_seed():
    a = make_scene("pcb", (80, 120), GRID, margin=4, seed=11)
    b = make_scene("pcb", (80, 120), GRID, margin=4, seed=11)
    c = make_scene("pcb", (80, 120), GRID, margin=4, seed=12)
    assert np.array_equal(a.labels, b.labels)
    assert not np.array_equal(a.labels, c.labels)
    assert set(np.unique(a.labels).tolist()) <= {0, 1, 2, 3}
    assert (a.labels == 1).mean() > 0.02  # there are tracks


def test_truth_scene_cube_is_on_the_slm_grid(sim_rig):
    cube, wavelengths = truth(sim_rig).scene_cube("white")
    assert cube.shape == (400, 640, wavelengths.size)
    assert wavelengths[0] == 390 and wavelengths[-1] == 720
    assert np.allclose(cube, 0.98)
