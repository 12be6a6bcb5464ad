"""The compiled SLIC and the re-segmentation's assignment against plain numpy."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from sassi_bench.snapshot import _kernels, _slic
from sassi_bench.snapshot.adaptive import segment_around_samples
from sassi_bench.snapshot.superpixels import superpixels


def _brute_assignment(features, samples, radius, weight):
    """Every pixel's nearest sample (SLIC distance, 3 x 3 mean features) within reach."""
    h, w, _ = features.shape
    yy, xx = np.mgrid[:h, :w]
    best = np.full((h, w), np.inf)
    labels = np.full((h, w), -1)
    for n, (r, c) in enumerate(samples):  # a test oracle: a few samples
        centre = features[max(0, r - 1) : r + 2, max(0, c - 1) : c + 2].reshape(-1, 3).mean(0)
        d = ((features - centre) ** 2).sum(-1) + weight * ((yy - r) ** 2 + (xx - c) ** 2)
        reach = (np.abs(yy - r) <= radius) & (np.abs(xx - c) <= radius)
        better = reach & (d < best)
        best[better], labels[better] = d[better], n
    return labels


def test_the_vectorised_assignment_is_the_nearest_sample_within_reach():
    rng = np.random.default_rng(0)
    features = rng.uniform(0, 50, (40, 60, 3)).astype(np.float32)
    samples = np.stack([rng.integers(0, 40, 25), rng.integers(0, 60, 25)], 1).astype(np.int64)
    labels = np.full((40, 60), -1, np.int32)
    distance = np.full((40, 60), np.inf, np.float32)
    _kernels.assign_to_samples(
        _kernels.planes(features), samples, 6, np.float32(0.5), labels, distance
    )
    np.testing.assert_array_equal(labels, _brute_assignment(features, samples, 6, 0.5))
    # The public function fills what no sample reaches with the nearest sample.
    full = segment_around_samples(features, samples)
    assert (full >= 0).all()


def test_shrinking_and_enlarging_the_grid():
    planes = np.arange(2 * 5 * 7, dtype=np.float32).reshape(2, 5, 7)
    small = _slic.halve(planes)
    assert small.shape == (2, 2, 3)
    assert small[1, 1, 2] == pytest.approx(planes[1, 2:4, 4:6].mean())
    labels = np.arange(6, dtype=np.int32).reshape(2, 3)
    big = _slic.enlarge(labels, 5, 7)
    assert big.shape == (5, 7) and big[4, 6] == 5 and big[1, 1] == 0 and big[2, 2] == 4


def test_connectivity_gives_every_component_its_own_label_and_absorbs_small_ones():
    labels = np.zeros((20, 20), np.int32)
    labels[:, 10:] = 1
    labels[2:4, 2:4] = 1  # a 4-pixel island of label 1 inside label 0
    labels[15:20, 0:5] = 1  # a 25-pixel island, big enough to stay
    out, count = _slic.connect(labels, 10)
    assert count == 3
    for k in range(count):
        assert ndimage.label(out == k)[1] == 1  # one connected component each
    assert (out[2:4, 2:4] == out[0, 0]).all()  # the island joined its surroundings
    assert out[17, 2] != out[0, 0]


def test_a_video_carries_the_centres_one_per_grid_cell():
    grid = _slic.grid_centres(np.zeros((1, 40, 40), np.float32), 10)
    assert grid.shape == (16, 2)
    previous = np.array([[3.0, 3.0], [4.0, 4.0], [38.0, 38.0], [100.0, 5.0]], np.float32)
    carried = _slic.carry_centres(previous, grid, 40, 40, 10)
    assert carried.shape == grid.shape
    np.testing.assert_array_equal(carried[0], [4.0, 4.0])  # the one nearer the cell's centre
    np.testing.assert_array_equal(carried[15], [38.0, 38.0])
    np.testing.assert_array_equal(carried[1:15], grid[1:15])  # the rest: the grid


def test_superpixels_from_the_last_centres_follow_the_regions():
    rng = np.random.default_rng(1)
    colours = rng.uniform(size=(16, 3)).astype(np.float32)
    yy, xx = np.mgrid[:128, :128]

    def squares(dy, dx):  # 4 x 4 squares of 32 px, moved by (dy, dx)
        return np.clip((yy - dy) // 32, 0, 3) * 4 + np.clip((xx - dx) // 32, 0, 3)

    first = superpixels(colours[squares(0, 0)], 16, shrink=2)
    moved = squares(3, 5)
    second = superpixels(colours[moved], 16, shrink=2, seeds=first.centres)
    assert second.centres.shape == first.centres.shape
    # The superpixels of the moved image lie mostly within one square each (two SLIC
    # iterations: 0.86 to 1.0 of each superpixel's pixels in one square, 0.95 on average).
    purity = [
        np.bincount(moved[second.labels == k]).max() / np.count_nonzero(second.labels == k)
        for k in range(second.count)
    ]
    assert min(purity) > 0.8 and np.mean(purity) > 0.9
    with pytest.raises(ValueError, match="seeds"):
        superpixels(colours[moved], 16, shrink=2, seeds=np.zeros((3, 3)))
