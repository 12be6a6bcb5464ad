"""Spectra at the open pixels of a frame rendered from the bundle's own frame model."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import ndtr

from sassi_bench.errors import ProcedureError
from sassi_bench.maths.normal import ramp
from sassi_bench.snapshot import measure_samples, uniform_mask
from sassi_bench.spectra.geometry import streak_geometry

CAMERA = (2048, 2048)


def render(bundle, rows, cols, spectra, background):
    """Each (pixel, bin)'s light uniform over the bin's columns, Gaussian-blurred in both
    directions (the model extraction inverts), on a smooth background."""
    geo = streak_geometry(bundle, rows, cols)
    core = geo.core
    frame = background.copy()
    for n in range(rows.size):  # a fixture: a few dozen synthetic streaks
        sigma = geo.sigma[n, core]
        xl, xr, y = geo.x_left[n, core], geo.x_right[n, core], geo.y[n, core]
        c0, c1 = int(xl.min() - 5 * sigma.max()), int(xr.max() + 5 * sigma.max()) + 2
        r0, r1 = int(y.min() - 5 * sigma.max()), int(y.max() + 5 * sigma.max()) + 2
        c = np.arange(c0, c1)[None, :]
        r = np.arange(r0, r1)[None, :]
        s, width = sigma[:, None], (xr - xl)[:, None]
        columns = (s / width) * (
            ramp((c + 0.5 - xl[:, None]) / s)
            - ramp((c + 0.5 - xr[:, None]) / s)
            - ramp((c - 0.5 - xl[:, None]) / s)
            + ramp((c - 0.5 - xr[:, None]) / s)
        )
        lines = ndtr((r + 0.5 - y[:, None]) / s) - ndtr((r - 0.5 - y[:, None]) / s)
        frame[r0:r1, c0:c1] += np.einsum("b,br,bc->rc", spectra[n], lines, columns)
    return frame


@pytest.fixture(scope="module")
def scene(synthetic_bundle, synthetic_spacing):
    mask = uniform_mask(synthetic_spacing, (7, 11))
    rows, cols = np.nonzero(mask)
    lam = synthetic_bundle.wavelengths
    rng = np.random.default_rng(0)
    peak = rng.uniform(450, 650, rows.size)[:, None]
    spectra = rng.uniform(200, 2000, (rows.size, 1)) * (0.3 + np.exp(-(((lam - peak) / 60.0) ** 2)))
    yy, xx = np.mgrid[: CAMERA[0], : CAMERA[1]] / 2048.0
    background = 100.0 + 20.0 * xx + 10.0 * yy**2  # dark level and leakage, smooth
    frame = render(synthetic_bundle, rows, cols, spectra, background)
    return mask, spectra, frame


def test_spectra_of_the_open_pixels_are_recovered(synthetic_bundle, scene):
    mask, spectra, frame = scene
    original = frame.copy()
    measured, units = measure_samples(frame, mask, synthetic_bundle, exposure_s=0.5)
    assert units == "relative photon radiance per bin"
    np.testing.assert_array_equal(frame, original)  # the caller's frame is left alone
    recovered = measured * synthetic_bundle.response * 0.5
    error = np.abs(recovered - spectra) / spectra.max(axis=1, keepdims=True)
    # The background is removed and no streak leaks into another: the median error is
    # 0.25 % of each spectrum's peak. The synthetic bundle blurs the ends by up to 8 px
    # (several bins), where the deblur's smoothing costs up to 30 %; where the blur is
    # under 1.5 px the worst bin is 3.3 % off (next to the blurry ones).
    sharp = synthetic_bundle.blur_width(synthetic_bundle.wavelengths) < 1.5
    assert sharp.sum() > 20
    assert np.percentile(error[:, sharp], 95) < 0.01 and error[:, sharp].max() < 0.04
    assert np.median(error) < 0.005
    # The same pixels given as (row, column) give the same spectra, in that order.
    pixels = np.argwhere(mask)[::-1]
    again, _ = measure_samples(frame, pixels, synthetic_bundle, exposure_s=0.5)
    np.testing.assert_allclose(again, measured[::-1])


def test_a_closed_slm_frame_removes_a_leak_the_estimate_cannot_follow(synthetic_bundle, scene):
    mask, spectra, frame = scene
    rows = np.arange(CAMERA[0])[:, None]
    # A leak with structure every 6 rows (a scene's edges, dispersed), up to 600 ADU: the
    # blocks' medians between the streaks cannot follow it under them.
    leak = 300.0 * (1 + np.sin(2 * np.pi * rows / 6.0)) * np.linspace(0, 1, CAMERA[1])[None, :]
    yy, xx = np.mgrid[: CAMERA[0], : CAMERA[1]] / 2048.0
    closed = 100.0 + 20.0 * xx + 10.0 * yy**2 + leak  # the scene's background, and the leak
    leaky = frame + leak

    def error(measured):
        recovered = measured * synthetic_bundle.response * 0.5
        return np.abs(recovered - spectra) / spectra.max(axis=1, keepdims=True)

    estimated, _ = measure_samples(leaky, mask, synthetic_bundle, exposure_s=0.5)
    subtracted, _ = measure_samples(leaky, mask, synthetic_bundle, exposure_s=0.5, closed=closed)
    # Measured: median error 15.8 % of each spectrum's peak from the estimate, 0.22 % with
    # the closed frame (as without the leak: the smooth background is in it too).
    assert np.median(error(estimated)) > 0.08
    assert np.median(error(subtracted)) < 0.004
    with pytest.raises(ProcedureError, match="closed-SLM frame"):
        measure_samples(leaky, mask, synthetic_bundle, exposure_s=0.5, closed=closed[:-1])


def test_bad_frames_and_pixels_are_refused(synthetic_bundle, scene):
    mask, _, frame = scene
    with pytest.raises(ProcedureError, match="one spectral-camera frame"):
        measure_samples(frame[None], mask, synthetic_bundle, exposure_s=1.0)
    with pytest.raises(ProcedureError, match="mask has shape"):
        measure_samples(frame, mask[:10], synthetic_bundle, exposure_s=1.0)
    with pytest.raises(ProcedureError, match="exposure_s"):
        measure_samples(frame, mask, synthetic_bundle, exposure_s=0.0)


@pytest.fixture(scope="module")
def dense_snapshot(calibrated_sim):
    """A dense snapshot of the natural scene on the sim rig (a random mask at a 6 px row
    pitch: streaks of neighbouring columns overlap) and, as its reference, the same open
    pixels in pinhole frames that keep the default rule (no two footprints meet), each
    minus a frame with the SLM closed, as the pinhole scan removes the leakage."""
    from sassi_bench.bundle import load
    from sassi_bench.snapshot import mask_conflicts, random_mask
    from sassi_bench.spectra.deblur import SpectralDeblur

    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    dense, sparse = bundle.mask_spacing(row_pitch=6), bundle.mask_spacing()
    mask = random_mask(dense, seed=0)
    deblur = SpectralDeblur.from_bundle(bundle)
    rig.set_scene("natural")
    rig.light.select("led")
    exposure = 0.08  # the auto-exposure's choice for this mask and light, about 0.09 s
    rig.spectral_camera.set_exposure(exposure)

    def capture(open_pixels):
        rig.slm.show(np.where(open_pixels, 255, 0).astype(np.uint8))
        return rig.spectral_camera.capture().data.astype(np.float64)

    frame, closed = capture(mask), capture(np.zeros_like(mask))
    assert 0.3 < frame.max() / 65535 < 0.95  # well exposed, nothing saturated
    # Rows of one band of `dense.pitch` rows keep disjoint camera columns (the dense rule);
    # bands of one subset are at least `sparse.pitch` rows apart. The few pixels the default
    # rule's wider column windows still forbid wait for a further frame.
    subsets = -(-(sparse.pitch - 1) // dense.pitch) + 1
    bands = np.arange(mask.shape[0]) // dense.pitch % subsets
    order = np.full(mask.shape, -1)
    order[mask] = np.arange(mask.sum())
    reference = np.full((int(mask.sum()), bundle.wavelengths.size), np.nan)
    remaining, frames = mask.copy(), 0
    while remaining.any():
        for k in range(subsets):
            pinholes = remaining & (bands == k)[:, None]
            while (conflicts := mask_conflicts(pinholes, sparse)).size:
                pinholes[tuple(conflicts[0])] = False
            if pinholes.any():
                spectra, _ = measure_samples(
                    capture(pinholes) - closed, pinholes, bundle, exposure_s=exposure, deblur=deblur
                )
                reference[order[pinholes]] = spectra
                remaining &= ~pinholes
                frames += 1
    assert frames <= 2 * subsets
    return bundle, deblur, mask, frame, exposure, reference, closed


def _psnr_db(estimate, reference):
    return 10 * np.log10(reference.max() ** 2 / np.mean((estimate - reference) ** 2))


def test_dense_snapshot_spectra_agree_with_pinhole_frames(dense_snapshot):
    from sassi_bench.spectra.crosstalk import columns_interact

    bundle, deblur, mask, frame, exposure, reference, _ = dense_snapshot
    rows, cols = np.nonzero(mask)
    assert mask.sum() > 250
    assert columns_interact(streak_geometry(bundle, rows, cols))
    refined, _ = measure_samples(frame, mask, bundle, exposure_s=exposure, deblur=deblur)
    first, _ = measure_samples(
        frame, mask, bundle, exposure_s=exposure, deblur=deblur, background_passes=0
    )
    accuracy, unrefined = _psnr_db(refined, reference), _psnr_db(first, reference)
    # Measured 42.5 dB, against 24.3 dB from the footprint-based background alone: a dense
    # mask leaves too few free camera pixels to see the closed pixels' leakage under the
    # streaks, and the refinements from the fitted streaks' residual recover it.
    assert accuracy > 38.0
    assert accuracy > unrefined + 12.0


def test_dense_snapshot_spectra_with_a_closed_slm_frame(dense_snapshot):
    bundle, deblur, mask, frame, exposure, reference, closed = dense_snapshot
    subtracted, _ = measure_samples(
        frame, mask, bundle, exposure_s=exposure, deblur=deblur, closed=closed
    )
    refined, _ = measure_samples(frame, mask, bundle, exposure_s=exposure, deblur=deblur)
    accuracy, estimated = _psnr_db(subtracted, reference), _psnr_db(refined, reference)
    # Measured 47.08 dB, against 45.48 dB from the refined estimate of the leakage (the
    # reference's pinhole frames subtract the same closed frame, so its noise is shared).
    assert accuracy > 44.0
    assert accuracy > estimated
