"""Patch localisation on pictures of the simulated chart (no scan needed)."""

import colour
import numpy as np
import pytest

from sassi_bench.rig.sim.scenes import colorchecker_layout, colorchecker_scene
from sassi_bench.validate.colorimetry import reflectance_to_xyz
from sassi_bench.validate.locate import LocateError, detect_chart, grid_from_corners
from sassi_bench.validate.reference import reference_chart

SLM = (400, 640)
GRID = np.arange(390.0, 722.0, 2.0)


def _true_centres(rotation_deg: float) -> np.ndarray:
    """Patch centres (u, v) of the simulated chart, from its layout."""
    lay = colorchecker_layout(SLM, 0, rotation_deg)
    rows, cols = np.divmod(np.arange(24), 6)
    local = np.stack([(cols - 2.5) * lay["pitch"], (rows - 1.5) * lay["pitch"]], axis=1)
    t = np.deg2rad(rotation_deg)
    rot = np.array([[np.cos(t), -np.sin(t)], [np.sin(t), np.cos(t)]])
    return local @ rot.T + [lay["centre_col"], lay["centre_row"]]


def _picture(rotation_deg: float, noise: float = 0.01, seed: int = 0) -> np.ndarray:
    scene = colorchecker_scene(SLM, GRID, 0, rotation_deg=rotation_deg)
    cube = scene.cube(SLM)
    rgb = colour.XYZ_to_sRGB(reflectance_to_xyz(GRID, cube))
    rng = np.random.default_rng(seed)
    return np.clip(rgb + rng.normal(0, noise, rgb.shape), 0, 1)


def _reference_rgb() -> np.ndarray:
    chart = reference_chart()
    xyz = reflectance_to_xyz(chart.wavelengths_nm, chart.reflectance)
    return colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=False)


@pytest.mark.parametrize("rotation_deg", [1.5, -4.0])
def test_detector_finds_every_patch_centre(rotation_deg):
    grid = detect_chart(_picture(rotation_deg), _reference_rgb())
    error = np.linalg.norm(grid.centres() - _true_centres(rotation_deg), axis=1)
    assert grid.detected >= 22  # the black patch melts into the black frame
    # px, including the patches it did not see: measured 0.135 (1.5 degrees), 0.038 (-4)
    assert error.max() < 0.27


def test_detector_reads_the_chart_upside_down():
    picture = _picture(1.5)[::-1, ::-1]
    grid = detect_chart(picture, _reference_rgb())
    h, w = SLM
    flipped = np.array([w - 1, h - 1]) - _true_centres(1.5)
    # Patch 1 (dark skin) is now at the bottom right: found there by its colour.
    assert np.linalg.norm(grid.centres() - flipped, axis=1).max() < 0.5


def test_labels_cover_patch_interiors_only():
    rotation = 1.5
    grid = detect_chart(_picture(rotation), _reference_rgb())
    labels = grid.labels(SLM, interior=0.5)
    scene = colorchecker_scene(SLM, GRID, 0, rotation_deg=rotation)
    inside = labels >= 0
    assert np.all(scene.labels[inside] == labels[inside] + 2)
    pitch = colorchecker_layout(SLM, 0, rotation)["pitch"]
    counts = np.bincount(labels[inside], minlength=24)
    assert np.all(np.abs(counts - (0.5 * pitch) ** 2) < 0.1 * (0.5 * pitch) ** 2)


def test_manual_corners_give_the_same_grid():
    true = _true_centres(1.5)
    grid = grid_from_corners(true[[0, 5, 23, 18]])
    assert np.abs(grid.centres() - true).max() < 1e-4  # px (OpenCV solves in float32)
    with pytest.raises(ValueError, match=r"patches 1, 6, 24 and 19"):
        grid_from_corners(true[:3])


def test_a_picture_without_a_chart_is_refused_with_a_fix():
    flat = np.full((*SLM, 3), 0.4)
    with pytest.raises(LocateError, match=r"--corners"):
        detect_chart(flat, _reference_rgb())
