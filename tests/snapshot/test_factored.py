"""Factored cubes: the rank-1 factors and the low-rank guided filter against dense results."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.errors import ProcedureError
from sassi_bench.snapshot import (
    Rank1Cube,
    guided_cube,
    guided_factors,
    random_mask,
    rank1_factors,
    segment_around_samples,
    spectral_basis,
)


def guide_and_regions(helpers, seed=0):
    spacing = helpers.odd_spacing(shape=(48, 80))
    rng = np.random.default_rng(seed)
    guide = rng.uniform(0.2, 2.0, (*spacing.slm_shape, 3)).astype(np.float32)
    mask = random_mask(spacing, seed=seed + 1)
    samples = np.argwhere(mask)[::2]
    labels = segment_around_samples(guide, samples)
    return guide, mask, labels


def dense_rank1(guide, labels, mask, spectra):
    """The rank-1 cube written out the long way, in float64."""
    intensity = guide.astype(np.float64).sum(axis=2)
    n = int(labels.max()) + 1
    owner = labels[mask]
    summed = np.zeros((n, spectra.shape[1]))
    np.add.at(summed, owner, spectra)
    light = np.bincount(owner, intensity[mask], n)
    ratio = np.divide(summed, light[:, None], out=np.zeros_like(summed), where=light[:, None] > 0)
    return intensity[..., None] * ratio[labels]


def test_factored_rank1_equals_the_dense_rank1_to_float32_precision(helpers):
    guide, mask, labels = guide_and_regions(helpers)
    spectra = np.random.default_rng(3).uniform(0.0, 500.0, (int(mask.sum()), 68))
    factored = rank1_factors(guide, labels, mask, spectra)
    assert isinstance(factored, Rank1Cube)
    assert factored.spectra.shape == (int(labels.max()) + 1, 68)
    reference = dense_rank1(guide, labels, mask, spectra)
    cube = factored.dense()
    np.testing.assert_allclose(cube, reference, rtol=4 * np.finfo(np.float32).eps, atol=0)
    # A band and a few pixels read without the dense cube agree with it exactly.
    np.testing.assert_array_equal(factored.band(17), cube[..., 17])
    rows, cols = np.array([0, 5, 47]), np.array([3, 70, 79])
    np.testing.assert_array_equal(factored.at(rows, cols), cube[rows, cols])
    # Written into a reused array, the same cube.
    out = np.full(factored.shape, np.nan, np.float32)
    assert factored.dense(out) is out
    np.testing.assert_array_equal(out, cube)
    with pytest.raises(ProcedureError, match="out has shape"):
        factored.dense(np.empty((2, 2, 2), np.float32))


def test_guided_filter_in_a_spectral_basis_is_exact_for_spectra_of_that_rank(helpers):
    guide, mask, _ = guide_and_regions(helpers, seed=4)
    rng = np.random.default_rng(5)
    # Spectra spanned by 3 basis spectra: a rank-3 projection loses nothing.
    spectra = rng.uniform(0, 1, (int(mask.sum()), 3)) @ rng.uniform(0, 1, (3, 40))
    full = guided_cube(guide, mask, spectra, radius=10, rank=None)
    low = guided_factors(guide, mask, spectra, radius=10, rank=3)
    assert low.coefficients.shape == (*mask.shape, 3) and low.basis.shape == (3, 40)
    np.testing.assert_allclose(low.dense(), full, rtol=1e-4, atol=1e-4 * np.abs(full).max())
    np.testing.assert_allclose(low.band(7), full[..., 7], atol=1e-4 * np.abs(full).max())
    # Rank 1 of rank-3 spectra: the projection shows.
    rank1 = guided_factors(guide, mask, spectra, radius=10, rank=1).dense()
    assert np.abs(rank1 - full).max() > 1e-2 * np.abs(full).max()
    with pytest.raises(ProcedureError, match="rank is 0"):
        guided_factors(guide, mask, spectra, rank=0)


def test_spectral_basis_is_orthonormal_and_ordered_by_energy():
    rng = np.random.default_rng(6)
    spectra = rng.normal(size=(200, 12)) * np.linspace(5, 0.5, 12)
    basis = spectral_basis(spectra, 4)
    np.testing.assert_allclose(basis @ basis.T, np.eye(4), atol=1e-12)
    energy = ((spectra @ basis.T) ** 2).sum(axis=0)
    assert np.all(np.diff(energy) <= 0)
