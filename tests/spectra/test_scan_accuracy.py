"""A full default pinhole scan of the ColorChecker, scored against the bench's ground truth.

Against the truth cube integrated into the same bins (default sim rig, default noise). The
bounds sit within about twice the measured error (the measured value beside each), so a
regression fails; the issue's targets (PSNR >= 40 dB, mean spectral angle <= 1.5 degrees,
offset residual <= 1 % of the mean streak signal) are far looser.
"""

import numpy as np
import pytest
from scipy import ndimage

from sassi_bench.bundle import load
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.scan import run_scan


@pytest.fixture(scope="module")
def colorchecker_scan(calibrated_sim):
    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    run = run_scan(rig, bundle, scene="colorchecker", light="led", data=data, progress=False)
    expected = truth(rig).binned_cube(bundle.bin_edges, "led", "colorchecker")
    return rig, run, expected


def _scores(cube, expected, measured):
    a, b = cube[measured].astype(np.float64), expected[measured]
    cosine = (a * b).sum(1) / (np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1))
    angle = np.degrees(np.arccos(np.clip(cosine, -1.0, 1.0)))
    gain = (a * b).sum() / (b * b).sum()  # the one overall gain (ADU per electron etc.)
    psnr = 10 * np.log10((gain * b).max() ** 2 / np.mean((a - gain * b) ** 2))
    return angle, psnr


def test_full_scan_meets_the_accuracy_targets(colorchecker_scan):
    _, run, expected = colorchecker_scan
    scan = run.scan
    measured = scan.quality == 0
    assert measured.mean() > 0.95  # the whole field is scanned; only edge streaks flagged
    angle, psnr = _scores(scan.cube, expected, measured)
    assert psnr >= 51.5  # measured 56.9 dB (an error 1.9x larger fails)
    assert angle.mean() <= 1.4  # degrees; measured 0.78
    # Bright patches are much better than the mean, which the dark surround dominates.
    bright = np.linalg.norm(expected[measured], axis=1)
    assert angle[bright > np.median(bright)].mean() <= 1.0  # measured 0.61


def test_full_scan_offset_residual(colorchecker_scan):
    rig, run, _ = colorchecker_scan
    scan = run.scan
    bench = truth(rig).bench
    exposure = run.session.plan.steps[run.session.plan.select(role="pinholes")[0]].exposure_s
    bench.set_scene("colorchecker")
    bench.set_light("led")
    electrons = (bench._background_rate() + bench.sensor.dark_current_e_per_s) * exposure
    true_background = electrons / bench.sensor.gain_e_per_adu + bench.sensor.dark_offset_adu
    estimated = np.isfinite(scan.background)  # the rows that streaks reach
    residual = np.sqrt(np.mean((scan.background - true_background)[estimated] ** 2))
    assert residual <= 1.3e-4 * scan.mean_streak_signal  # measured 6.8e-5 of it


def _scatter_psnr(cube, expected, measured, erode=7, window=15):
    """Per-band PSNR of the cube's scatter about its local mean in the interiors of the
    truth's uniform regions (the chart's patches, mat and surround): its noise, measured."""
    flat = expected.reshape(-1, expected.shape[-1])
    _, labels = np.unique(np.round(flat / flat.max(), 6), axis=0, return_inverse=True)
    labels = labels.reshape(measured.shape)
    inner = np.zeros(measured.shape, bool)
    for label in np.unique(labels):
        inner |= ndimage.binary_erosion(labels == label, iterations=erode)
    inner &= measured
    weight = ndimage.uniform_filter(inner.astype(np.float64), window)
    peak = float(cube[measured].max())
    psnr = []
    for band in np.moveaxis(cube.astype(np.float64), -1, 0):
        values = np.where(inner, band, 0.0)
        local = ndimage.uniform_filter(values, window) / np.maximum(weight, 1e-12)
        psnr.append(20 * np.log10(peak / np.sqrt(np.mean((values - local)[inner] ** 2))))
    return np.array(psnr)


def test_the_cube_states_its_own_noise_in_every_band(colorchecker_scan):
    # The stated noise (band_noise_psnr_db) against the scatter of the cube where the
    # truth is uniform. Each bin's own variance and its covariance with its neighbours
    # (shared camera columns) are what make it hold: with one variance for all bins the
    # statement was up to 8.7 dB optimistic at the red end and 2.8 dB pessimistic in the
    # blue; per bin without the covariance, 2.2-3.5 dB optimistic in every band.
    _, run, expected = colorchecker_scan
    scan = run.scan
    measured = _scatter_psnr(scan.cube, expected, scan.quality == 0)
    offset = scan.band_noise_psnr_db - measured
    assert np.all(np.abs(offset) <= 2.5), np.round(offset, 1)  # measured at most 1.85 dB
    assert abs(float(np.median(offset))) <= 1.2, np.round(offset, 1)  # measured 0.82 dB
