"""Reconstruction on synthetic cubes with known answers, and the metrics against hand values."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

from sassi_bench.errors import ProcedureError
from sassi_bench.snapshot import (
    band_psnr,
    guided_cube,
    mean_spectral_angle_deg,
    psnr,
    random_mask,
    rank1_cube,
    segment_around_samples,
    snapshot_dataset,
    ssim,
    write_cube,
)


def smooth_guide(shape, seed=0):
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[: shape[0], : shape[1]] / 7.0
    base = 2.0 + np.sin(xx + rng.uniform(0, 6)) * np.cos(0.7 * yy) + 0.3 * rng.random(shape)
    return np.stack([base, 0.5 * base, 0.8 * base + 0.2], axis=-1)


def test_rank1_is_exact_on_a_piecewise_rank1_cube(helpers):
    spacing = helpers.odd_spacing(shape=(48, 80))
    guide = smooth_guide(spacing.slm_shape)
    intensity = guide.sum(axis=2)
    mask = random_mask(spacing, seed=1)
    samples = np.argwhere(mask)[::2]  # half the open pixels own regions
    labels = segment_around_samples(guide.astype(np.float32), samples)
    spectra_of_region = np.random.default_rng(2).uniform(0.5, 2.0, (len(samples), 6))
    truth = intensity[..., None] * spectra_of_region[labels]
    measured = truth[mask]
    cube = rank1_cube(guide, labels, mask, measured)
    assert cube.dtype == np.float32 and cube.shape == truth.shape
    np.testing.assert_allclose(cube, truth, rtol=2e-6)


def test_guided_filter_is_exact_where_the_cube_is_affine_in_the_guide(helpers):
    spacing = helpers.odd_spacing(shape=(48, 80))
    guide = smooth_guide(spacing.slm_shape, seed=3)
    intensity = guide.sum(axis=2)
    normalised = intensity / intensity.max()
    slope, offset = np.linspace(1, 3, 5), np.linspace(-0.5, 0.5, 5)
    truth = normalised[..., None] * slope + offset
    mask = random_mask(spacing, seed=2)
    cube = guided_cube(guide, mask, truth[mask], radius=12, eps=1e-9)
    np.testing.assert_allclose(cube, truth, atol=2e-4)
    # A ridge shrinks the slope towards the window's mean: no longer exact.
    blurred = guided_cube(guide, mask, truth[mask], radius=12, eps=1.0)
    assert np.abs(blurred - truth).max() > 0.01


def test_guided_filter_averages_noise_that_rank1_keeps(helpers):
    spacing = helpers.odd_spacing(shape=(64, 96), seed=4)
    guide = smooth_guide(spacing.slm_shape, seed=5)
    intensity = guide.sum(axis=2)
    truth = intensity[..., None] * np.linspace(1.0, 2.0, 4)
    mask = random_mask(spacing, seed=6)
    noisy = truth[mask] + np.random.default_rng(7).normal(0, 0.5, (mask.sum(), 4))
    samples = np.argwhere(mask)
    labels = segment_around_samples(guide.astype(np.float32), samples)
    rank1 = rank1_cube(guide, labels, mask, noisy)
    guided = guided_cube(guide, mask, noisy)  # default window and ridge
    assert psnr(truth, guided) > psnr(truth, rank1) + 5  # measured: 38.7 against 30.4 dB


def test_metrics_against_hand_computed_values():
    ref = np.zeros((2, 2, 2))
    ref[..., 0] = [[4.0, 2.0], [2.0, 2.0]]
    ref[..., 1] = 1.0
    est = ref.copy()
    est[0, 0, 0] = 3.0  # one error of 1 in 8 values: MSE 1/8, peak 4
    assert psnr(ref, est) == pytest.approx(10 * np.log10(16 * 8))
    assert band_psnr(ref, est).tolist() == pytest.approx([10 * np.log10(16 * 4), np.inf])
    assert psnr(ref, 0.5 * ref - 1, affine=True) == np.inf
    assert psnr(ref, est, valid=np.array([[False, True], [True, True]])) == np.inf
    # Spectral angle: (3, 1) against (4, 1); other pixels exact.
    angle = np.degrees(np.arccos(13 / np.sqrt(10 * 17)))
    assert mean_spectral_angle_deg(ref, est) == pytest.approx(angle / 4)
    cube = np.random.default_rng(0).random((12, 12, 3))
    assert ssim(cube, cube) == pytest.approx(1.0)
    assert ssim(cube, 1.0 - cube) < 0  # anti-correlated structure
    with pytest.raises(ProcedureError, match="compare cubes of one shape"):
        psnr(ref, est[0])


def test_reconstruction_refuses_mismatched_input():
    with pytest.raises(ProcedureError, match="one spectrum per open pixel"):
        rank1_cube(np.ones((4, 4)), np.zeros((4, 4), int), np.array([[0, 0]]), np.ones((2, 3)))
    with pytest.raises(ProcedureError, match="same SLM grid"):
        rank1_cube(np.ones((4, 5)), np.zeros((4, 4), int), np.array([[0, 0]]), np.ones((1, 3)))
    with pytest.raises(ProcedureError, match="mask has shape"):
        guided_cube(np.ones((4, 4)), np.ones((3, 3), bool), np.ones((9, 2)))


def test_cubes_are_written_like_scan_cubes(synthetic_bundle, tmp_path):
    h, w = synthetic_bundle.slm_shape
    cube = np.random.default_rng(0).random((h, w, synthetic_bundle.wavelengths.size))
    ds = snapshot_dataset(
        cube, synthetic_bundle, units="camera ADU per second per bin", method="rank-1"
    )
    paths = write_cube(ds, tmp_path / "snap.nc", envi=tmp_path / "snap")
    back = xr.open_dataset(paths[0])
    np.testing.assert_allclose(back["radiance"].values, cube.astype(np.float32))
    assert back.attrs["bundle_version"] == synthetic_bundle.version
    assert back["wavelength"].values.tolist() == pytest.approx(synthetic_bundle.wavelengths)
    assert paths[1].with_suffix(".img").exists()
    back.close()
    with pytest.raises(ProcedureError, match="reconstruct with this bundle"):
        snapshot_dataset(cube[:10], synthetic_bundle, units="x", method="rank-1")
