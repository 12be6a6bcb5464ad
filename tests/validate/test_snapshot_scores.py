"""Snapshot scores summed block by block from factored cubes equal the whole-cube metrics."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.snapshot import (
    LowRankCube,
    Rank1Cube,
    band_psnr,
    mean_spectral_angle_deg,
    psnr,
    ssim,
)
from sassi_bench.validate.snapshot import Scores, cube_psnr

RNG = np.random.default_rng(2)
SHAPE = (70, 45, 9)  # more rows than one block


@pytest.fixture(scope="module")
def cubes():
    labels = RNG.integers(0, 12, SHAPE[:2])
    scale = RNG.uniform(0.5, 2.0, SHAPE[:2]).astype(np.float32)
    spectra = RNG.uniform(0.1, 1.0, (12, SHAPE[2])).astype(np.float32)
    rank1 = Rank1Cube(labels, scale, spectra)
    basis = np.linalg.qr(RNG.normal(size=(SHAPE[2], 4)))[0].T.astype(np.float32)
    low = LowRankCube(RNG.normal(1.0, 0.3, (*SHAPE[:2], 4)).astype(np.float32), basis)
    reference = (rank1.dense() + RNG.normal(0, 0.05, SHAPE)).astype(np.float32)
    reference[3, 4] = 0.0  # a zero spectrum: no angle
    valid = RNG.random(SHAPE[:2]) > 0.2
    valid[:5] = False  # the bounding box is not the whole cube
    return rank1, low, reference, valid


@pytest.mark.parametrize("which", ["rank1", "low_rank", "dense"])
def test_scores_equal_the_metrics_on_the_dense_cube(cubes, which):
    rank1, low, reference, valid = cubes
    estimate = {"rank1": rank1, "low_rank": low, "dense": rank1.dense()}[which]
    dense = estimate if isinstance(estimate, np.ndarray) else estimate.dense()
    score = Scores.of(estimate, reference, valid)
    assert score.psnr_db == pytest.approx(psnr(reference, dense, valid=valid), abs=1e-9)
    assert score.psnr_affine_db == pytest.approx(
        psnr(reference, dense, valid=valid, affine=True), abs=1e-9
    )
    np.testing.assert_allclose(
        score.band_psnr_db, band_psnr(reference, dense, valid=valid), rtol=0, atol=1e-9
    )
    assert score.spectral_angle_deg == pytest.approx(
        mean_spectral_angle_deg(reference, dense, valid=valid), abs=1e-9
    )
    rows, cols = np.nonzero(valid)
    box = (slice(rows.min(), rows.max() + 1), slice(cols.min(), cols.max() + 1))
    inside = np.where(valid[box][..., None], dense[box], reference[box])
    # float32 band products of a low-rank cube may round apart from its dense product
    assert score.ssim == pytest.approx(ssim(reference[box], inside), abs=1e-8)


def test_psnr_on_a_subset_with_a_given_peak(cubes):
    rank1, _, reference, valid = cubes
    detail = valid & (RNG.random(valid.shape) > 0.7)
    expected = psnr(reference, rank1.dense(), valid=detail, peak=7.0)
    assert cube_psnr(rank1, reference, detail, peak=7.0) == pytest.approx(expected, abs=1e-9)


def test_a_cube_of_another_shape_is_refused(cubes):
    rank1, _, reference, valid = cubes
    with pytest.raises(ValueError, match="snapshot scores: the estimate is"):
        Scores.of(rank1.dense()[:, :-1], reference, valid)
