"""The exported files used the way the SASSI authors' code uses them, on a virtual-bench
snapshot, against this project's spectrum extraction.

The authors' extraction (``get_cassi_cube`` in their ``modules/cassi.py``) is re-written
here from its description, in numpy/scipy/OpenCV (their code needs torch and a compiled
module):

1. streak image: per band, the mask sampled bilinearly (zeros outside) through
   ``calibstack_row/col - 1`` as ``grid_sample`` does with their normalisation, which
   reads the SLM at ``c - 0.5``; blurred by their ``gaussdiskwin(ksizes[k])`` window
   (direct convolution, so untouched pixels stay exactly 0); summed over bands;
2. offset: every pixel takes the value of the nearest pixel where the streak image is 0
   (``griddata(..., method="nearest")``); subtracted, negatives clipped;
3. a 3-row vertical box sum, then ``cv2.remap`` at column ``Yl - 1``, row ``Xl - 1`` for
   every open SLM pixel.

Their values are point samples of a 3-row sum, ours (``extract_spectra`` without the
deblur) the bin's whole light: the expected ratio per pixel and bin is the share of the
spot's rows inside the 3-row window (bilinear in the bin's row position, from the
bundle's blur sigma) over the bin's width in camera columns. Our reference extraction
subtracts the true background (the same exposure with the SLM closed).

The last tests score both against the virtual bench's truth with the row window the
export writes (``vsize``, ``row_window_share``), the way a lab would run their code on
our files.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy import ndimage, signal
from scipy.io import loadmat
from scipy.special import ndtr

from sassi_bench.export.adaptive_cassi import export_adaptive_cassi
from sassi_bench.rig.sim import truth
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.extract import extract_spectra
from sassi_bench.spectra.geometry import streak_geometry


def gaussdisk_factor(k: float) -> np.ndarray:
    """1-D factor of the authors' ``gaussdiskwin(k)`` (a separable Gaussian window of
    ``2 ceil(k - 0.5) + 1`` px whose FWHM is the window), normalised like their code."""
    size = 2 * int(np.ceil(k - 0.5)) + 1
    window = signal.windows.gaussian(size, size / (2 * np.sqrt(2 * np.log(2))))
    return (window / window.sum()).astype(np.float32)


def streak_image(mask, calibstack_row, calibstack_col, ksizes) -> np.ndarray:
    """Step 1: where the streaks of the mask fall (``get_cassi_img`` of an all-ones cube)."""
    out = np.zeros(calibstack_row.shape[:2], np.float32)
    for k in range(calibstack_row.shape[2]):
        # grid_sample(align_corners=False) of (2c - H) / H reads the SLM at c - 0.5.
        sampled = cv2.remap(
            mask,
            calibstack_col[..., k] - 1.5,
            calibstack_row[..., k] - 1.5,
            cv2.INTER_LINEAR,
            borderMode=cv2.BORDER_CONSTANT,
            borderValue=0,
        )
        w = gaussdisk_factor(ksizes[k])
        out += ndimage.convolve1d(
            ndimage.convolve1d(sampled, w, axis=0, mode="constant"), w, axis=1, mode="constant"
        )
    return out


def authors_spectra(calib, reverse, capture, ksizes, vsize=3):
    """Steps 1-3: spectra (N, T) of the open pixels, and the pixels' (rows, cols)."""
    mask = capture["lcos_mask"].astype(np.float32) / 255
    image = capture["cassi_img"].astype(np.float32)
    streaks = streak_image(mask, calib["calibstack_row"], calib["calibstack_col"], ksizes)
    _, (iy, ix) = ndimage.distance_transform_edt(streaks != 0, return_indices=True)
    clean = np.clip(image - image[iy, ix], 0, None)
    # convolve2d(img, ones((vsize, 1)), 'same') with its zero padding, for odd vsize.
    summed = ndimage.convolve1d(clean, np.ones(vsize, np.float32), axis=0, mode="constant")
    rows, cols = np.nonzero(mask > 0)
    x_map = np.ascontiguousarray(reverse["Yl"][rows, cols] - 1.0, dtype=np.float32)
    y_map = np.ascontiguousarray(reverse["Xl"][rows, cols] - 1.0, dtype=np.float32)
    return rows, cols, cv2.remap(summed, x_map, y_map, cv2.INTER_LINEAR), (streaks == 0).mean()


def three_row_gain(geometry, blur, wavelengths) -> np.ndarray:
    """Expected (authors' value) / (bin's light) per pixel and bin, (N, B)."""
    core = geometry.core
    y = geometry.y[:, core]
    width = geometry.x_right[:, core] - geometry.x_left[:, core]
    # The continuous profile that the window sums integrate: a "psf_quadratic" blur is the
    # spot before the camera pixel; a "quadratic" one is its second moment on camera
    # pixels, whose own 1/12 px^2 is taken out.
    s = np.asarray(blur.sigma(wavelengths), dtype=np.float64)
    if blur.kind == "quadratic":
        s = np.sqrt(np.maximum(s**2 - 1.0 / 12.0, 1e-6))
    top = np.floor(y)
    frac = y - top

    def window(row):
        return ndtr((row + 1.5 - y) / s) - ndtr((row - 1.5 - y) / s)

    return ((1.0 - frac) * window(top) + frac * window(top + 1.0)) / width


@pytest.fixture(scope="module")
def comparison(sim_bundle, snapshot_session, loaded, tmp_path_factory):
    bundle, _ = sim_bundle
    calib, reverse = loaded
    done = export_adaptive_cassi(
        bundle, snapshot_session, 0, tmp_path_factory.mktemp("capture"), guide_steps=[2]
    )
    capture = loadmat(done.path)
    frame = snapshot_session.read_frame(0).astype(np.float64)
    background = snapshot_session.read_frame(1).astype(np.float64)
    rows, cols, _, _ = authors_spectra(calib, reverse, capture, calib["ksizes"].ravel())
    geometry = streak_geometry(bundle, rows, cols)
    ours, off_frame = extract_spectra(frame - background, geometry, deblur=None)
    assert not off_frame.any()
    gain = three_row_gain(geometry, bundle.models.blur, bundle.wavelengths)
    level = ours.mean(axis=1)
    # The chart's patches; the black patch and the dark surround are left out.
    bright = level > 0.2 * np.percentile(level, 95)
    assert bright.sum() >= 80
    return calib, reverse, capture, frame, background, ours, gain, bright


def errors(theirs, ours, gain, bright):
    """Per bright pixel: RMS difference over the bins relative to the RMS spectrum, and
    the spectral angle (degrees)."""
    scaled = theirs[bright] / gain[bright]
    reference = ours[bright]
    rel = np.sqrt(((scaled - reference) ** 2).mean(1) / (reference**2).mean(1))
    norms = np.linalg.norm(scaled, axis=1) * np.linalg.norm(reference, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):  # a spectrum of zeros has no angle
        cos = (scaled * reference).sum(1) / norms
    angle = np.degrees(np.arccos(np.clip(np.nan_to_num(cos), -1, 1)))
    return rel, angle


def test_remap_through_xl_yl_reads_the_streaks(comparison):
    """Step 3 alone, on the frame minus its true background: the spectra read through
    Xl/Yl agree with ours within 8 % RMS per pixel (measured: median 4.0 %, max 6.4 %;
    photon noise is under 1 %, the rest is the difference of the two estimators: a
    3-row point sample against a bin's whole light, and the gain model, a Gaussian where
    the bench's spot is a tent under one) and 3 degrees (median 2.0), with per-bin gains
    within 9 % of the model (measured 0.94-1.08, the last bin the farthest)."""
    _, reverse, capture, frame, background, ours, gain, bright = comparison
    mask = capture["lcos_mask"] > 0
    rows, cols = np.nonzero(mask)
    clean = (frame - background).astype(np.float32)
    summed = ndimage.convolve1d(clean, np.ones(3, np.float32), axis=0, mode="constant")
    theirs = cv2.remap(
        summed,
        np.ascontiguousarray(reverse["Yl"][rows, cols] - 1.0),
        np.ascontiguousarray(reverse["Xl"][rows, cols] - 1.0),
        cv2.INTER_LINEAR,
    )
    rel, angle = errors(theirs, ours, gain, bright)
    assert np.median(rel) < 0.045 and rel.max() < 0.08
    assert np.median(angle) < 2.5 and angle.max() < 3.0
    ratio = theirs[bright] / (ours[bright] * gain[bright])
    assert np.all(np.abs(np.median(ratio, axis=0) - 1) < 0.09)
    # The swapped reading (Xl as columns) samples empty camera: it must not agree.
    wrong = cv2.remap(
        summed,
        np.ascontiguousarray(reverse["Xl"][rows, cols] - 1.0),
        np.ascontiguousarray(reverse["Yl"][rows, cols] - 1.0),
        cv2.INTER_LINEAR,
    )
    assert np.median(errors(wrong, ours, gain, bright)[0]) > 0.5


def test_authors_pipeline_with_the_exported_blur(comparison):
    """Steps 1-3 on the raw frame with ``ksizes`` from calibstack.mat, their own offset
    estimate included: within 8 % RMS for 90 % of the pixels (measured: median 3.7 %,
    90th percentile 5.7 %, max 11.5 % next to the SLM's top edge) and 3.5 degrees."""
    calib, reverse, capture, _, _, ours, gain, bright = comparison
    _, _, theirs, free = authors_spectra(calib, reverse, capture, calib["ksizes"].ravel())
    assert 0.3 < free < 0.9
    rel, angle = errors(theirs, ours, gain, bright)
    assert np.median(rel) < 0.05 and np.percentile(rel, 90) < 0.08
    assert np.median(angle) < 2.5 and np.percentile(angle, 90) < 3.5


def test_hard_coded_blur_loses_the_blue(comparison):
    """With cassi.py's hard-coded ``ksizes`` (0.25-4 px windows, narrowest in the blue)
    rows of streak light count as streak-free and are subtracted as offset: the bluest
    bins lose most of their signal. This is why README.txt suggests the exported ksizes."""
    calib, reverse, capture, _, _, ours, gain, bright = comparison
    t = calib["wavelengths"].size
    hard_coded = np.linspace(1, 4, t) ** 2 / 4
    _, _, theirs, _ = authors_spectra(calib, reverse, capture, hard_coded)
    ratio = np.median(theirs[bright] / (ours[bright] * gain[bright]), axis=0)
    blue = calib["wavelengths"].ravel() < 415
    assert ratio[blue].max() < 0.6
    assert np.median(errors(theirs, ours, gain, bright)[0]) > 0.08


def psnr_one_gain(estimate, reference) -> float:
    """PSNR (dB) of spectra (N, B) against the truth after one least-squares gain for all
    pixels and bands (as the scan accuracy tests score): per-band errors count."""
    gain = (estimate * reference).sum() / (reference * reference).sum()
    peak = (gain * reference).max()
    return float(10 * np.log10(peak**2 / np.mean((estimate - gain * reference) ** 2)))


@pytest.fixture(scope="module")
def against_truth(comparison, calibrated_sim, sim_bundle, snapshot_session):
    """PSNR at the open pixels against the truth: the authors' extraction with the
    exported window (and with others), ours with and without the spectral deblur."""
    bundle, _ = sim_bundle
    calib, reverse, capture, frame, background, ours_plain, _, _ = comparison
    ksizes = calib["ksizes"].ravel()
    vsize = int(calib["vsize"].item())  # what a lab's cassi.py line becomes
    rows, cols, theirs, _ = authors_spectra(calib, reverse, capture, ksizes, vsize=vsize)
    light = snapshot_session.plan.steps[0].light
    scene = snapshot_session.plan.parameters["scene"]
    reference = truth(calibrated_sim[0]).binned_cube(bundle.bin_edges, light, scene)[rows, cols]
    # Their value is the light of one camera column: per bin it is that times the columns
    # a bin spans (about 1 on the sim bench, whose bins are one column wide).
    columns_per_bin = np.diff(bundle.bin_edges) / calib["nm_per_column"].ravel()
    share = calib["row_window_share"].ravel()
    geometry = streak_geometry(bundle, rows, cols)
    deblurred, _ = extract_spectra(
        frame - background, geometry, deblur=SpectralDeblur.from_bundle(bundle)
    )
    wide = 2 * int(np.ceil(calib["blur_sigma_px"].max())) + 1
    _, _, theirs_wide, _ = authors_spectra(calib, reverse, capture, ksizes, vsize=wide)
    scores = {
        "theirs": psnr_one_gain(theirs / share * columns_per_bin, reference),
        "theirs_undivided": psnr_one_gain(theirs * columns_per_bin, reference),
        "theirs_wide_undivided": psnr_one_gain(theirs_wide * columns_per_bin, reference),
        "ours": psnr_one_gain(deblurred, reference),
        "ours_without_deblur": psnr_one_gain(ours_plain, reference),
    }
    print("PSNR (dB) at the open pixels against the truth:", scores)  # shown with -s
    return vsize, wide, scores


def test_authors_extraction_with_the_exported_window_is_as_good_as_ours_without_deblur(
    against_truth,
):
    """With ``vsize`` from calibstack.mat and the cube divided by ``row_window_share``
    their extraction is within 2 dB of ours without its spectral deblur (measured: 33.5
    against 32.5 dB), and far better than without the division (24.2 dB: the red bands
    keep a third of their light in 3 rows) or with the window the widest blur implies
    and no division (the issue's ask: 30.0 dB at 9 rows; wider windows add their offset
    estimate's noise)."""
    vsize, wide, scores = against_truth
    assert vsize == 3 and wide == 9
    assert scores["theirs"] >= scores["ours_without_deblur"] - 2.0, scores
    assert scores["theirs"] >= scores["theirs_undivided"] + 5.0, scores
    assert scores["theirs"] >= scores["theirs_wide_undivided"] + 2.0, scores


def test_the_spectral_deblur_is_what_their_code_misses(against_truth):
    """ "Within 2 dB of our own extraction" cannot be met by their algorithm: it does not
    undo the spectral blur, which is worth 6.6 dB here (39.1 against 32.5 dB at the open
    pixels; 5.5 dB on an adaptive snapshot of the natural scene). Their extraction sits at
    our no-deblur level."""
    _, _, scores = against_truth
    assert scores["ours"] - scores["ours_without_deblur"] >= 4.0, scores
    assert scores["ours"] - scores["theirs"] >= 4.0, scores
