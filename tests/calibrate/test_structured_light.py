"""Structured-light decoding of one axis and of both: masks, counts, the virtual bench."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from scipy.special import ndtr

import sassi_bench
from sassi_bench.acquire.patterns import gray_bit_count, render_pattern
from sassi_bench.calibrate.grey_response import measure_grey_response, sinusoid_profile
from sassi_bench.calibrate.phase_decode import blur_from_modulation
from sassi_bench.calibrate.pixel_validity import REASONS
from sassi_bench.calibrate.structured_light import (
    AxisDecode,
    decode_axis,
    decode_correspondences,
)
from sassi_bench.rig.sim import truth

BLOCK, PERIOD, STEPS = 8, 16, 8


def sweep_descriptors(axis: str, length: int, profile) -> dict[str, list[dict]]:
    """Pattern descriptors of one axis, as the sweep plan shows them."""
    bits = range(gray_bit_count(length, BLOCK))
    gray = {"kind": "gray", "axis": axis, "block": BLOCK}
    return {
        "positive": [{**gray, "bit": b, "inverse": False} for b in bits],
        "negative": [{**gray, "bit": b, "inverse": True} for b in bits],
        "phase": [
            {"kind": "periodic", "axis": axis, "profile": [int(p) for p in profile],
             "shift": s * PERIOD // STEPS}
            for s in range(STEPS)
        ],
    }  # fmt: skip


# -- a synthetic bench: known smooth warp, Gaussian blur, SLM gamma, shot and read noise ----
class SyntheticBench:
    """Camera (150, 200) viewing an SLM (120, 160) through a known smooth warp.

    Patterns along one axis are separable, so the blurred image is exactly
    ``(T * G)(u) (rect * G)(v)`` (or with u and v swapped): 1-D edge sums of normal CDFs,
    tabulated finely and interpolated at each camera pixel's SLM coordinate.
    """

    slm = (120, 160)
    camera = (150, 200)
    gain = 0.458  # e- per ADU
    eps = 1e-3

    def __init__(self, sigma_slm: float = 1.2, electrons: float = 20000.0, seed: int = 0):
        self.sigma = sigma_slm
        self.rng = np.random.default_rng(seed)
        y, x = np.mgrid[0 : self.camera[0], 0 : self.camera[1]].astype(np.float64)
        xc, yc = x - 100.0, y - 75.0
        self.u = 79.5 + 0.92 * xc + 0.015 * yc + 1.5e-4 * xc**2 - 1e-4 * xc * yc
        self.v = 59.5 + 0.91 * yc - 0.012 * xc + 1.2e-4 * yc**2 + 0.8e-4 * xc**2
        self.light = electrons * (1.0 - 0.15 * ((xc / 100) ** 2 + (yc / 75) ** 2))
        self.light[(x - 60) ** 2 + (y - 50) ** 2 < 8**2] = 0.0  # an opaque speck: dark
        self.light[95:110, 130:150] *= 2.5  # a hot spot: saturates in bright frames
        self.dark = self._digitise(np.zeros(self.camera))

    def _blurred(self, transmission: np.ndarray, coord: np.ndarray) -> np.ndarray:
        """Transmission per SLM pixel (0 outside the SLM), blurred, at ``coord``."""
        steps = np.diff(np.concatenate([[0.0], transmission, [0.0]]))
        edges = np.arange(transmission.size + 1) - 0.5
        fine = np.arange(-10.0, transmission.size + 10.0, 1 / 32)
        table = ndtr((fine[:, None] - edges[None, :]) / self.sigma) @ steps
        return np.clip(np.interp(coord, fine, table), 0.0, None)  # no -1e-17 rounding

    def _digitise(self, electrons: np.ndarray) -> np.ndarray:
        e = self.rng.poisson(electrons) + self.rng.normal(0.0, 5.0, electrons.shape)
        return np.clip(np.rint(np.minimum(e, 30000) / self.gain + 100), 0, 65535).astype(np.uint16)

    def capture(self, descriptor: dict) -> np.ndarray:
        pattern = render_pattern(descriptor, self.slm).astype(np.float64)
        t = self.eps + (1 - self.eps) * (pattern / 255.0) ** 2.2
        along_x = descriptor.get("axis", "x") == "x"
        profile_u = t[0] if along_x else np.ones(self.slm[1])
        profile_v = np.ones(self.slm[0]) if along_x else t[:, 0]
        image = self._blurred(profile_u, self.u) * self._blurred(profile_v, self.v)
        return self._digitise(self.light * image)

    def capture_axis(self, axis: str, profile) -> dict[str, np.ndarray]:
        length = self.slm[1] if axis == "x" else self.slm[0]
        plan = sweep_descriptors(axis, length, profile)
        return {k: np.stack([self.capture(d) for d in ds]) for k, ds in plan.items()}


def compensated_profile(bench: SyntheticBench) -> np.ndarray:
    """The sinusoid profile precompensated for the bench's measured grey-level response."""
    levels = np.array([*range(0, 256, 32), 255])
    uniform = np.stack([bench.capture({"kind": "uniform", "level": int(g)}) for g in levels])
    return sinusoid_profile(PERIOD, measure_grey_response(levels, uniform, bench.dark))


def decode_synthetic(bench: SyntheticBench) -> tuple[dict[str, AxisDecode], object]:
    """Run the whole sweep on a synthetic bench: grey response, both axes, pairs."""
    refs = {k: bench.capture({"kind": k}) for k in ("blank", "full")}
    profile = compensated_profile(bench)
    axes = {}
    for axis in ("x", "y"):
        frames = bench.capture_axis(axis, profile)
        length = bench.slm[1] if axis == "x" else bench.slm[0]
        axes[axis] = decode_axis(
            frames["positive"], frames["negative"], frames["phase"],
            length=length, dark=bench.dark, **refs,
        )  # fmt: skip
    return axes, decode_correspondences(axes["x"], axes["y"])


def warp_errors(bench: SyntheticBench, pairs) -> tuple[np.ndarray, np.ndarray]:
    rows, cols = pairs.y.astype(int), pairs.x.astype(int)
    return pairs.u - bench.u[rows, cols], pairs.v - bench.v[rows, cols]


@pytest.fixture(scope="module")
def synthetic():
    bench = SyntheticBench()
    return bench, *decode_synthetic(bench)


@pytest.mark.parametrize("sigma", [0.55, 2.8])
def test_decoding_holds_over_the_blur_range(sigma):
    bench = SyntheticBench(sigma_slm=sigma, seed=3)
    axes, pairs = decode_synthetic(bench)
    du, dv = warp_errors(bench, pairs)
    # Measured at 0.55 and 2.8 SLM px: RMS 0.021 and 0.037, worst 0.061 and 0.111, the
    # blur 0.0015 and 0.0043 off.
    assert np.sqrt(np.mean(du**2 + dv**2)) < 0.05
    assert np.abs(np.concatenate([du, dv])).max() < 0.2
    assert axes["x"].blur_sigma == pytest.approx(np.sqrt(sigma**2 + 1 / 12), abs=0.009)
    inside = (bench.u > 8) & (bench.u < 151) & (bench.v > 8) & (bench.v < 111)
    assert pairs.valid[inside & (bench.light > 0)].mean() > 0.97


def test_synthetic_warp_is_recovered_to_a_few_hundredths_of_a_pixel(synthetic):
    bench, _, pairs = synthetic
    du, dv = warp_errors(bench, pairs)
    rms_u, rms_v = np.sqrt(np.mean(du**2)), np.sqrt(np.mean(dv**2))
    assert rms_u < 0.033 and rms_v < 0.033  # measured 0.016 and 0.017
    assert np.sqrt(np.mean(du**2 + dv**2)) < 0.046  # measured 0.023
    # No systematic shift: measured 0.00017 and 0.00003 (noise; held to 0.001).
    assert abs(du.mean()) < 0.001 and abs(dv.mean()) < 0.001
    assert np.abs(np.concatenate([du, dv])).max() < 0.13  # measured 0.065


def test_synthetic_validity_counts(synthetic):
    bench, axes, pairs = synthetic
    inside = (bench.u > -0.5) & (bench.u < 159.5) & (bench.v > -0.5) & (bench.v < 119.5)
    speck = bench.light == 0
    hot = np.zeros(bench.camera, bool)
    hot[95:110, 130:150] = True
    reason = np.array(REASONS)[pairs.reason]
    # The speck is dark and counted; the hot spot is saturated (full frame at 65535).
    assert set(reason[speck]) == {"dark"}
    assert set(reason[hot]) == {"saturated"}
    assert pairs.counts["saturated"] == hot.sum() == 300
    # Outside the SLM's image: dark, or (within the blur's reach) an excluded edge.
    assert set(reason[~inside]) == {"dark", "edge"}
    far = (bench.u < -5) | (bench.u > 164) | (bench.v < -5) | (bench.v > 124)
    assert set(reason[far]) == {"dark"}
    assert pairs.counts["dark"] >= speck.sum() + far.sum()
    # Counts add up, and match the maps.
    assert sum(pairs.counts[r] for r in REASONS) == pairs.counts["pixels"] == 30000
    assert pairs.counts["valid"] == len(pairs) == pairs.valid.sum()
    for name, code in zip(REASONS, range(len(REASONS)), strict=True):
        assert pairs.counts[name] == int((pairs.reason == code).sum())
    # Every other pixel more than the edge margin inside the SLM's image is valid.
    margin = axes["x"].edge_margin + 0.2
    core = (
        (bench.u > margin - 0.5) & (bench.u < 159.5 - margin)
        & (bench.v > margin - 0.5) & (bench.v < 119.5 - margin) & ~hot & ~speck
    )  # fmt: skip
    assert pairs.valid[core].all()
    assert not pairs.valid[~inside].any()
    assert set(reason[inside & ~core & ~hot & ~speck]) == {"valid", "edge"}


def test_blur_and_edge_margin_come_from_the_modulation(synthetic):
    bench, axes, _ = synthetic
    # The SLM pixel's box (variance 1/12) adds to the Gaussian blur.
    expected = np.sqrt(bench.sigma**2 + 1 / 12)
    for axis in axes.values():
        assert axis.blur_sigma == pytest.approx(expected, abs=0.03)
        assert axis.edge_margin == pytest.approx(0.5 + 2.5 * axis.blur_sigma)
    assert blur_from_modulation(np.exp(-2 * np.pi**2 * 0.25 / 256), 16) == pytest.approx(0.5)


def test_correspondence_arrays_match_the_maps(synthetic):
    _, axes, pairs = synthetic
    rows, cols = pairs.y.astype(int), pairs.x.astype(int)
    assert np.array_equal(pairs.u, pairs.u_map[rows, cols])
    assert np.array_equal(pairs.v, axes["y"].coord[rows, cols])
    assert np.isnan(pairs.u_map[~pairs.valid]).all()
    assert np.isfinite(pairs.v_map[pairs.valid]).all()


# -- errors -----------------------------------------------------------------------------
def test_errors_name_step_cause_and_fix():
    frames = np.zeros((4, 3, 5))
    gray = frames[:1]  # 5 px in blocks of 8: one Gray bit
    refs = {"blank": frames[0], "full": frames[0], "length": 5}
    decode_axis(gray, gray, frames, **refs)  # well-formed input decodes (to all dark)
    with pytest.raises(ValueError, match="structured-light decoding: full has shape"):
        decode_axis(gray, gray, frames, **{**refs, "full": np.zeros((3, 4))})
    with pytest.raises(ValueError, match="structured-light decoding: dark has shape"):
        decode_axis(gray, gray, frames, **refs, dark=np.ones(3))
    with pytest.raises(ValueError, match="structured-light decoding: phase has shape"):
        decode_axis(gray, gray, frames[:2], **refs)
    with pytest.raises(ValueError, match="4 Gray bits given; 5 px in blocks of 8 need 1"):
        decode_axis(frames, frames, frames, **refs)
    with pytest.raises(ValueError, match="Gray blocks of 16 px cannot pick a period of 16"):
        decode_axis(gray, gray, frames, **refs, block=16)
    with pytest.raises(ValueError, match=r"length 0 is not a positive integer.*SLM's width"):
        decode_axis(gray, gray, frames, **{**refs, "length": 0})


def test_each_exclusion_reason_is_detected_where_expected():
    """A noiseless camera that sees the SLM pixel for pixel, with one defect per patch."""
    shape, length = (40, 64), 64

    def show(descriptor):
        return 100.0 + 1000.0 * render_pattern(descriptor, shape) / 255.0

    plan = sweep_descriptors("x", length, sinusoid_profile(PERIOD))
    frames = {k: np.stack([show(d) for d in ds]) for k, ds in plan.items()}
    blank, full = show({"kind": "blank"}), show({"kind": "full"})
    full[0:5, 10:20] = blank[0:5, 10:20]  # dark: no light at all
    frames["positive"][2, 5:10, 10:20] = 65535  # saturated in one frame
    frames["phase"][:, 10:15, 10:20] = 600.0  # no fringes
    frames["negative"][1:3, 15:20, 10:20] = frames["positive"][1:3, 15:20, 10:20]  # 2 bits lost
    frames["phase"][:, 20:25] = np.roll(frames["phase"][:, 20:25], PERIOD // 2, axis=2)
    axis = decode_axis(
        frames["positive"], frames["negative"], frames["phase"],
        blank=blank, full=full, length=length, dark=100.0,
    )  # fmt: skip
    expected = np.zeros(shape, np.uint8)
    expected[0:5, 10:20] = REASONS.index("dark")
    expected[5:10, 10:20] = REASONS.index("saturated")
    expected[10:15, 10:20] = REASONS.index("low_modulation")
    expected[15:20, 10:20] = REASONS.index("ambiguous_gray")
    # Fringes half a period off put the unwrapped phase 8 - |3.5 - p| px from the block
    # centre (p = position in the block): the check catches p = 2..5 (> 6 px away).
    p = np.arange(length) % BLOCK
    expected[20:25] = np.where(np.abs(3.5 - p) < 2, REASONS.index("disagreement"), 0)
    edge = np.arange(length) < axis.edge_margin - 0.5
    edge |= np.arange(length) > length - 0.5 - axis.edge_margin
    expected[:, edge] = np.where(expected[:, edge] == 0, REASONS.index("edge"), expected[:, edge])
    # Pixels the wrong fringes shift by a whole period may land near the border: skip them.
    compare = np.ones(shape, bool)
    compare[20:25, :BLOCK] = compare[20:25, -BLOCK:] = False
    # The other pixels of those rows are off by half a period, which the consistency
    # check cannot see; the outlier test catches them where their window holds more
    # good rows than shifted ones (most of rows 20 and 21); the band's middle agrees with
    # itself.
    shifted = compare & (expected == 0)
    shifted[:20] = shifted[25:] = False
    outlier = REASONS.index("outlier")
    assert np.mean(axis.reason[20:22][shifted[20:22]] == outlier) > 0.8
    assert set(axis.reason[shifted].tolist()) == {0, outlier}
    compare &= ~shifted
    np.testing.assert_array_equal(axis.reason[compare], expected[compare])
    assert axis.counts["dark"] == axis.counts["saturated"] == 50
    assert axis.counts["disagreement"] >= 5 * 4 * 6  # 4 of 8 px in the 6 interior blocks
    # Elsewhere the decode is exact.
    good = axis.reason == 0
    good[20:25] = False
    np.testing.assert_allclose(axis.coord[good], np.broadcast_to(np.arange(64.0), shape)[good],
                               atol=0.02)  # fmt: skip
    assert axis.blur_sigma < 0.2  # point-sampled, unblurred: only the profile's rounding


def test_outliers_are_pixels_that_disagree_with_their_neighbours(synthetic):
    """A wrong Gray word passes every per-pixel check; the smooth map gives it away."""
    bench = synthetic[0]
    refs = {k: bench.capture({"kind": k}) for k in ("blank", "full")}
    frames = bench.capture_axis("x", compensated_profile(bench))
    clean = decode_axis(frames["positive"], frames["negative"], frames["phase"],
                        length=bench.slm[1], dark=bench.dark, **refs)  # fmt: skip
    # Swap the last two Gray bits of a 3 x 4 px spot, as a flicker or a hot pixel might:
    # the block moves by two (one fringe period), so the unwrapped phase still agrees with
    # it and only the smooth map gives the pixels away.
    spot = (slice(70, 73), slice(100, 104))
    pos, neg = frames["positive"].copy(), frames["negative"].copy()
    for bit in (-2, -1):
        pos[bit][spot], neg[bit][spot] = (
            frames["negative"][bit][spot],
            frames["positive"][bit][spot],
        )
    broken = decode_axis(pos, neg, frames["phase"], length=bench.slm[1], dark=bench.dark, **refs)
    assert clean.valid[spot].all()
    assert np.all(np.abs(np.abs(broken.coarse[spot] - clean.coarse[spot]) - PERIOD) < 1e-9)
    assert (broken.reason[spot] == REASONS.index("outlier")).all()
    # Nothing else changes.
    elsewhere = np.ones(bench.camera, bool)
    elsewhere[spot] = False
    np.testing.assert_array_equal(broken.reason[elsewhere], clean.reason[elsewhere])
    assert clean.counts["outlier"] == 0


def test_correspondences_refuse_mismatched_or_empty_axes():
    def axis(shape, valid):
        ok = np.full(shape, valid)
        reason = np.where(ok, 0, 1).astype(np.uint8)
        return AxisDecode(
            np.zeros(shape), ok, np.ones(shape), {}, reason, np.zeros(shape), 0.5, 1.0
        )

    with pytest.raises(
        ValueError, match=r"correspondences: the x axis \(2, 3\) and the y axis \(3, 2\) differ"
    ):
        decode_correspondences(axis((2, 3), True), axis((3, 2), True))
    with pytest.raises(ValueError, match="correspondences: no pixel was decoded on both axes"):
        decode_correspondences(axis((2, 3), True), axis((2, 3), False))


# -- the virtual bench --------------------------------------------------------------------
RIGS = Path(__file__).parents[1] / "rigs"


def bench_sweep(rig, wavelength: float) -> tuple[dict[str, AxisDecode], object, object]:
    """A structured-light sweep of one laser on a (virtual) rig, decoded like the workflow.

    Exposed so the bright end of the full frame (99.9th percentile: hot pixels are not
    the scene) sits at about 60 % of the ADC range.
    """
    rig.set_scene("white")
    cam, shape, light = rig.spectral_camera, rig.slm.shape, f"laser:{wavelength:g}"

    def capture(descriptor):
        rig.slm.show(render_pattern(descriptor, shape))
        return cam.capture().data

    trial_s = 0.005
    cam.set_exposure(trial_s)
    rig.light.select("off")
    black = float(np.median(capture({"kind": "blank"})))
    rig.light.select(light)
    peak = float(np.percentile(capture({"kind": "full"}), 99.9)) - black
    cam.set_exposure(trial_s * 0.6 * (65535.0 - black) / peak)
    rig.light.select("off")
    dark = capture({"kind": "blank"})
    rig.light.select(light)
    blank, full = capture({"kind": "blank"}), capture({"kind": "full"})
    assert 0.5 * 65535 < np.percentile(full, 99.9) < 0.7 * 65535

    levels = np.array([*range(0, 256, 32), 255])
    uniform = np.stack([capture({"kind": "uniform", "level": int(g)}) for g in levels])
    response = measure_grey_response(levels, uniform, dark)
    profile = sinusoid_profile(PERIOD, response)

    decoded = {}
    for axis, length in (("x", shape[1]), ("y", shape[0])):
        plan = sweep_descriptors(axis, length, profile)
        frames = {k: np.stack([capture(d) for d in ds]) for k, ds in plan.items()}
        decoded[axis] = decode_axis(
            frames["positive"], frames["negative"], frames["phase"],
            blank=blank, full=full, length=length, dark=dark, saturation_level=65535,
        )  # fmt: skip
    return decoded, decode_correspondences(decoded["x"], decoded["y"]), response


def score_against_truth(rig, pairs, wavelength: float) -> dict[str, float]:
    """Camera and SLM RMS of the correspondences, their worst error, the decoded share."""
    bench_truth = truth(rig)
    x, y = bench_truth.slm_to_camera(pairs.u, pairs.v, wavelength)
    distance = np.hypot(x - pairs.x, y - pairs.y)
    u_true, v_true = bench_truth.bench.relay.inverse(pairs.x, pairs.y, wavelength)
    h, w = rig.spectral_camera.shape
    rows, cols = np.mgrid[0:h, 0:w].astype(np.float64)
    u_all, v_all = bench_truth.bench.relay.inverse(cols, rows, wavelength)
    sh, sw = rig.slm.shape
    lit = (u_all > -0.5) & (u_all < sw - 0.5) & (v_all > -0.5) & (v_all < sh - 0.5)
    return {
        "rms_camera": float(np.sqrt(np.mean(distance**2))),
        "rms_slm": float(np.sqrt(np.mean((pairs.u - u_true) ** 2 + (pairs.v - v_true) ** 2))),
        "p999": float(np.percentile(distance, 99.9)),
        "max": float(distance.max()),
        "valid_fraction": float((pairs.valid & lit).sum() / lit.sum()),
        "valid_outside": float((pairs.valid & ~lit).sum() / lit.sum()),
    }


def test_virtual_bench_sweep_at_532nm_matches_truth():
    start = time.perf_counter()
    rig = sassi_bench.open_rig("sim")
    decoded, pairs, response = bench_sweep(rig, 532.0)
    g = np.arange(256)
    assert np.abs(response(g) - (g / 255.0) ** rig.description.slm.gamma).max() < 1e-3
    score = score_against_truth(rig, pairs, 532.0)
    elapsed = time.perf_counter() - start
    print(
        f"\nvirtual bench 532 nm: {score}; blur sigma x {decoded['x'].blur_sigma:.3f}, "
        f"y {decoded['y'].blur_sigma:.3f} SLM px; counts {pairs.counts}; {elapsed:.1f} s"
    )
    # Measured: RMS 0.022 (camera) and 0.020 px (SLM), 0.057 px at the 99.9th percentile,
    # 98.5 % of the lit pixels valid.
    assert score["rms_camera"] < 0.045
    assert score["rms_slm"] < 0.04
    assert score["p999"] < 0.12  # "lands within the pixel", by far
    assert score["valid_fraction"] > 0.97
    assert score["valid_outside"] < 0.001
    lit = pairs.counts["pixels"] * score["valid_fraction"]
    assert pairs.counts["disagreement"] + pairs.counts["ambiguous_gray"] < 0.001 * lit


@pytest.mark.parametrize("name", ["nuisance-all", "nuisance-stray-light"])
def test_decoding_holds_up_under_the_real_bench_nuisances(name):
    """1 % laser power jitter, hot pixels, crosstalk, stray light and speckle at once
    (and stray light alone, which lights pixels the SLM's image never reaches) at the
    blurriest laser: every correspondence still lands within 0.1 px RMS of truth, and
    no pixel outside the SLM's image is taken."""
    rig = sassi_bench.open_rig(RIGS / f"{name}.yaml")
    _, pairs, _ = bench_sweep(rig, 635.0)
    score = score_against_truth(rig, pairs, 635.0)
    print(f"\n{name} 635 nm: {score}; counts {pairs.counts}")
    # Measured (all nuisances; stray light alone): RMS 0.035 and 0.027 px (camera), 0.033
    # and 0.025 px (SLM), 0.138 and 0.098 px at worst, 96.2 and 96.3 % of the lit valid.
    assert score["rms_camera"] <= 0.07
    assert score["rms_slm"] <= 0.066
    assert score["max"] < 0.28  # no wrong Gray word, no stray-lit pixel
    assert score["valid_fraction"] > 0.92
    assert score["valid_outside"] < 0.001
