"""Physics of the virtual bench's frames, scored against its ground truth."""

import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.patterns import pinhole_pattern
from sassi_bench.optics.sources import SpectralSamples
from sassi_bench.rig.config import rig_description_from_dict
from sassi_bench.rig.sim import truth
from sassi_bench.rig.sim.family import family_rigs
from sassi_bench.rig.sim.render import _interpolation_nodes


def _single_pixel(shape, u, v):
    pattern = np.zeros(shape, dtype=bool)
    pattern[v, u] = True
    return pattern


def _centroid(image, x0, y0, half, half_y=None):
    ys, xs = np.mgrid[0 : image.shape[0], 0 : image.shape[1]]
    half_y = half if half_y is None else half_y
    window = (np.abs(xs - x0) <= half) & (np.abs(ys - y0) <= half_y)
    w = np.where(window, image, 0.0)
    return (w * xs).sum() / w.sum(), (w * ys).sum() / w.sum()


@pytest.mark.parametrize("laser", [450.0, 532.0, 670.0])
@pytest.mark.parametrize(("u", "v"), [(320, 200), (15, 12), (620, 385), (90, 330)])
def test_one_open_pixel_lands_where_truth_says(sim_rig, laser, u, v):
    rig = sim_rig
    rig.set_scene("white")
    rig.light.select(f"laser:{laser:g}")
    rig.spectral_camera.set_exposure(0.2)
    rig.slm.show(np.zeros(rig.slm.shape, bool))
    dark = np.mean([rig.spectral_camera.capture().as_float() for _ in range(2)], axis=0)
    rig.slm.show(_single_pixel(rig.slm.shape, u, v))
    lit = np.mean([rig.spectral_camera.capture().as_float() for _ in range(2)], axis=0)
    x, y = truth(rig).slm_to_camera(u, v, laser)
    half = 4 * float(truth(rig).line_spread_sigma_px(laser)) + 2
    cx, cy = _centroid(lit - dark, float(x), float(y), half)
    assert cx == pytest.approx(float(x), abs=0.05)
    assert cy == pytest.approx(float(y), abs=0.05)


def test_sparse_rendering_conserves_energy_exactly(sim_rig):
    bench = truth(sim_rig).bench
    scene = bench.scene_named("colorchecker")
    samples = bench.samples("led")
    rows, cols = np.nonzero(pinhole_pattern(bench.slm_shape, offset=(37, 2)))
    transmission = np.linspace(0.2, 1.0, rows.size).astype(np.float32)
    rate = bench.renderer.render_sparse(rows, cols, transmission, scene, samples)
    spectra = scene.reflectance_at(rows + scene.margin, cols + scene.margin, samples.wavelengths_nm)
    expected = np.sum(
        transmission[:, None] * spectra * bench.renderer.electrons_per_photon(samples)
    )
    assert rate.sum() == pytest.approx(expected, rel=1e-4)


def test_dense_rendering_conserves_energy(sim_rig):
    bench = truth(sim_rig).bench
    scene = bench.scene_named("white")
    samples = bench.samples("halogen")
    transmission = np.zeros(bench.slm_shape, np.float32)
    transmission[50:350, 60:580] = 1.0  # keep the streaks away from the frame edges
    rate = bench.renderer.render_dense(transmission, scene, samples)
    per_pixel = np.sum(0.98 * bench.renderer.electrons_per_photon(samples))
    assert rate.sum() == pytest.approx(per_pixel * transmission.sum(), rel=2e-3)


@pytest.mark.parametrize("light", ["led", "laser:450", "laser:520", "laser:670"])
def test_sparse_and_dense_rendering_agree_on_extended_patterns(sim_rig, light):
    bench = truth(sim_rig).bench
    scene = bench.scene_named("colorchecker")
    samples = bench.samples(light)
    image = np.zeros(bench.slm_shape, np.float32)
    image[100:140, 200:240] = 1.0
    image[250:300, 420:430] = 0.5
    rows, cols = np.nonzero(image)
    sparse = bench.renderer.render_sparse(rows, cols, image[rows, cols], scene, samples)
    dense = bench.renderer.render_dense(image, scene, samples)
    assert dense.sum() == pytest.approx(sparse.sum(), rel=2e-3)
    assert np.linalg.norm(dense - sparse) / np.linalg.norm(sparse) < 0.03
    ys, xs = np.mgrid[0 : dense.shape[0], 0 : dense.shape[1]]
    for img in (dense, sparse):
        img /= img.sum()
    # The warped rendering point-samples pattern edges, worth a few hundredths of a pixel.
    assert (dense * xs).sum() == pytest.approx((sparse * xs).sum(), abs=0.1)
    assert (dense * ys).sum() == pytest.approx((sparse * ys).sum(), abs=0.1)


def test_sparse_and_dense_rendering_agree_on_pinholes_within_sampling_error(sim_rig):
    # Warping point-samples each isolated pixel's spot, so its energy depends on the
    # sub-pixel phase by a few per cent; that is why the bench splats sparse patterns.
    bench = truth(sim_rig).bench
    scene = bench.scene_named("colorchecker")
    samples = bench.samples("led")
    rows, cols = np.nonzero(pinhole_pattern(bench.slm_shape, pitch=(100, 20), offset=(30, 7)))
    sparse = bench.renderer.render_sparse(
        rows, cols, np.ones(rows.size, np.float32), scene, samples
    )
    image = np.zeros(bench.slm_shape, np.float32)
    image[rows, cols] = 1.0
    dense = bench.renderer.render_dense(image, scene, samples)
    assert dense.sum() == pytest.approx(sparse.sum(), rel=2e-3)
    assert np.linalg.norm(dense - sparse) / np.linalg.norm(sparse) < 0.1
    x, y = truth(sim_rig).slm_to_camera(cols, rows, samples.mean_wavelength_nm)
    for xi, yi in zip(x[::5], y[::5], strict=True):
        s = _centroid(sparse, xi, yi, 45, 8)
        d = _centroid(dense, xi, yi, 45, 8)
        # measured over every pinhole: at most 0.215 px apart (0.006 px on average)
        assert d == pytest.approx(s, abs=0.25)


def test_sparse_streaks_are_where_their_spectrum_puts_them(sim_rig):
    bench = truth(sim_rig).bench
    scene = bench.scene_named("colorchecker")
    samples = bench.samples("led")
    rows, cols = np.nonzero(pinhole_pattern(bench.slm_shape, pitch=(100, 40), offset=(30, 7)))
    rate = bench.renderer.render_sparse(rows, cols, np.ones(rows.size, np.float32), scene, samples)
    weights = scene.reflectance_at(rows + scene.margin, cols + scene.margin, samples.wavelengths_nm)
    weights = weights * bench.renderer.electrons_per_photon(samples)
    xs, ys = bench.relay.forward(cols[:, None], rows[:, None], samples.wavelengths_nm[None, :])
    expected_x = (weights * xs).sum(1) / weights.sum(1)
    expected_y = (weights * ys).sum(1) / weights.sum(1)
    for xi, yi in zip(expected_x, expected_y, strict=True):
        assert _centroid(rate, xi, yi, 50, 15) == pytest.approx((xi, yi), abs=0.01)


def test_finite_contrast_leaves_a_background_of_eps(sim_rig):
    rig = sim_rig
    bench = truth(rig).bench
    rig.set_scene("white")
    rig.light.select("led")
    closed = bench.renderer.render_dense(
        bench.transmission(np.zeros(bench.slm_shape, np.uint8)), bench.scene, bench.samples("led")
    )
    opened = bench.renderer.render_dense(
        bench.transmission(np.full(bench.slm_shape, 255, np.uint8)),
        bench.scene,
        bench.samples("led"),
    )
    centre = (slice(200, 300), slice(300, 500))
    ratio = closed[centre].mean() / opened[centre].mean()
    assert ratio == pytest.approx(truth(rig).contrast_eps, rel=1e-3)


def test_grey_levels_follow_the_slm_gamma(sim_rig):
    bench = truth(sim_rig).bench
    t = bench.transmission(np.array([0, 128, 255], np.uint8))
    eps, gamma = bench.eps, sim_rig.description.slm.gamma
    assert t == pytest.approx([eps, eps + (1 - eps) * (128 / 255) ** gamma, 1.0], rel=1e-6)


def test_captured_frames_match_the_rate_within_noise(sim_rig):
    rig = sim_rig
    bench = truth(rig).bench
    rig.set_scene("white")
    rig.light.select("laser:520")
    rig.slm.show(pinhole_pattern(rig.slm.shape, pitch=(40, 10)))
    rig.spectral_camera.set_exposure(0.01)  # well below saturation
    frame = rig.spectral_camera.capture().as_float()
    rate = bench.spectral_rate().astype(np.float64)
    assert rate.max() * 0.01 < 0.5 * bench.sensor.full_well_e
    sensor = bench.sensor
    electrons = (frame - sensor.dark_offset_adu) * sensor.gain_e_per_adu
    expected = (rate.sum() + sensor.dark_current_e_per_s * rate.size) * 0.01
    noise = np.sqrt(expected + rate.size * sensor.read_noise_e**2)
    assert electrons.sum() == pytest.approx(expected, abs=5 * noise)


def test_long_exposures_saturate_and_clip(sim_rig):
    rig = sim_rig
    rig.set_scene("white")
    rig.light.select("laser:532")
    rig.slm.show(pinhole_pattern(rig.slm.shape))
    rig.spectral_camera.set_exposure(5.0)
    frame = rig.spectral_camera.capture().data
    top = 2**rig.spectral_camera.bit_depth - 1
    assert (frame == top).sum() > 100
    assert frame.max() == top


def test_same_seed_same_frames_other_seed_other_noise(sim_dict, make_rig):
    def grab(data):
        rig = make_rig(data)
        rig.light.select("laser:450")
        rig.slm.show(pinhole_pattern(rig.slm.shape, pitch=(100, 50)))
        return rig.spectral_camera.capture().data

    a, b = grab(sim_dict), grab(sim_dict)
    assert np.array_equal(a, b)
    sim_dict["seed"] = sim_dict["seed"] + 1
    c = grab(sim_dict)
    assert not np.array_equal(a, c)
    assert abs(a.astype(float).mean() - c.astype(float).mean()) < 0.5


def test_truth_is_only_for_virtual_benches():
    from sassi_bench.rig.rig import Rig

    fake = Rig.__new__(Rig)
    with pytest.raises(ValueError, match="not a virtual bench"):
        truth(fake)


def test_prototype_scale_renders_a_pinhole_frame():
    rig = open_rig("sim-prototype")
    rig.light.select("laser:532")
    rig.slm.show(pinhole_pattern(rig.slm.shape, pitch=(100, 50), offset=(50, 25)))
    frame = rig.spectral_camera.capture()
    assert frame.shape == (2048, 2048)
    u, v = 950, 525
    x, y = truth(rig).slm_to_camera(u, v, 532.0)
    assert frame.data[round(float(y)), round(float(x))] > 5 * np.median(frame.data)


def test_the_same_state_is_rendered_once_and_its_rate_is_read_only(sim_rig):
    bench = truth(sim_rig).bench
    sim_rig.set_scene("white")
    sim_rig.light.select("laser:520")
    sim_rig.slm.show(pinhole_pattern(sim_rig.slm.shape, pitch=(40, 10)))
    first = bench.spectral_rate()
    assert bench.spectral_rate() is first
    assert not first.flags.writeable
    sim_rig.slm.show(pinhole_pattern(sim_rig.slm.shape, pitch=(40, 10), offset=(1, 0)))
    moved = bench.spectral_rate()
    assert moved is not first and not np.array_equal(moved, first)
    sim_rig.light.select("laser:532")
    assert not np.array_equal(bench.spectral_rate(), moved)


def test_dense_frames_are_the_same_with_kept_and_fresh_maps(sim_rig):
    bench = truth(sim_rig).bench
    renderer = bench.renderer
    scene, samples = bench.scene_named("colorchecker"), bench.samples("laser:450")
    image = np.zeros(bench.slm_shape, np.float32)
    image[:, ::16] = 1.0
    first = renderer.render_dense(image, scene, samples)  # maps made and kept
    assert renderer.render_dense(image, scene, samples).tobytes() == first.tobytes()
    # Maps solved after other wavelengths', or afresh, are the same maps.
    renderer.render_dense(image, scene, bench.samples("led"))
    renderer.use_relay(renderer.relay)
    assert not renderer._inverse_cache
    renderer.render_dense(image, scene, bench.samples("laser:670"))
    assert renderer.render_dense(image, scene, samples).tobytes() == first.tobytes()


def test_inverse_maps_are_the_relays_inverse_at_their_interpolation_nodes(sim_rig):
    renderer = truth(sim_rig).bench.renderer
    for lam in (405.0, 532.0, 698.0):
        u, v, _ = renderer._inverse_maps(lam)
        gx, gy = np.meshgrid(renderer._coarse_x, renderer._coarse_y)
        exact_u, exact_v = renderer.relay.inverse(gx, gy, lam, tol_px=1e-9)
        # float32 storage: within its resolution at coordinates of some hundred px.
        assert np.max(np.abs(u - _interpolation_nodes(exact_u))) < 1e-3
        assert np.max(np.abs(v - _interpolation_nodes(exact_v))) < 1e-3
        # the nodes move by a few thousandths of an SLM px
        assert 1e-4 < np.max(np.abs(u - exact_u)) < 0.05


@pytest.fixture(scope="module")
def curved_rig():
    """A family rig whose streaks bend (SF10, 59 px, small SLM): the inverse map curves."""
    return open_rig(rig_description_from_dict(family_rigs(45, 4, small=True)[3]))


@pytest.mark.parametrize("wavelength_nm", [450.0, 650.0])
def test_a_dense_fringe_is_where_the_ray_trace_puts_it(curved_rig, wavelength_nm):
    """Four phase-shifted fringes rendered densely decode to the ray trace's SLM column:
    measured 0.0003 (450 nm) and 0.0023 SLM px (650 nm) on average; a bilinear
    interpolant of the coarse inverse map's exact nodes left 0.0045-0.0062 px here."""
    bench = truth(curved_rig).bench
    renderer, samples = bench.renderer, SpectralSamples(np.array([wavelength_nm]), np.ones(1))
    height, width = bench.slm_shape
    columns = np.arange(width)[None, :] * np.ones((height, 1))
    period = 16.0
    frames = [
        renderer.render_dense(
            (0.5 + 0.5 * np.cos(2 * np.pi * columns / period + k * np.pi / 2)).astype(np.float32),
            bench.scene_named("white"),
            samples,
        ).astype(np.float64)
        for k in range(4)
    ]
    phase = np.arctan2(frames[3] - frames[1], frames[0] - frames[2])
    ys, xs = (g.ravel() for g in np.mgrid[0 : phase.shape[0] : 5, 0 : phase.shape[1] : 5])
    u, v = renderer.relay.inverse(xs.astype(float), ys.astype(float), wavelength_nm)
    inside = (u > 10) & (u < width - 10) & (v > 10) & (v < height - 10)
    fringe = phase[ys[inside], xs[inside]] - 2 * np.pi * u[inside] / period
    offset = np.angle(np.exp(1j * fringe)) * period / (2 * np.pi)
    assert inside.sum() > 500
    assert abs(offset.mean()) < 3e-3
    assert offset.std() < 0.01


def test_dense_rows_the_light_cannot_reach_are_dark_and_the_rest_match_a_full_warp(sim_rig):
    """The dense renderer warps only the rows the SLM's image reaches: compare with a
    frame warped over every row."""
    bench = truth(sim_rig).bench
    renderer = bench.renderer
    scene, samples = bench.scene_named("colorchecker"), bench.samples("laser:532")
    image = np.zeros(bench.slm_shape, np.float32)
    image[150:260, :] = 1.0
    rate = renderer.render_dense(image, scene, samples)
    rows = np.flatnonzero(rate.sum(axis=1) > 0)
    assert rows.size and rows[0] > 100 and rows[-1] < bench.camera_shape[0] - 100
    original = renderer._reached_rows
    renderer._reached_rows = lambda maps, shape: (0, bench.camera_shape[0])
    try:
        full = renderer.render_dense(image, scene, samples)
    finally:
        renderer._reached_rows = original
    assert np.array_equal(rate, full)


def test_the_closed_slm_background_with_coarser_samples_is_within_noise(sim_rig):
    from sassi_bench.optics.sources import coarser_samples

    bench = truth(sim_rig).bench
    scene, samples = bench.scene_named("colorchecker"), bench.samples("led")
    closed = np.full(bench.slm_shape, np.float32(bench.eps))
    full = bench.renderer.render_dense(closed, scene, samples)
    coarse = bench.renderer.render_dense(closed, scene, coarser_samples(samples, 2))
    assert coarse.sum() == pytest.approx(full.sum(), rel=1e-3)
    # At an exposure that fills the open streaks to 60 % of the well, the difference
    # is a small fraction of the noise.
    rows, cols = np.nonzero(pinhole_pattern(bench.slm_shape))
    open_rate = bench.renderer.render_sparse(
        rows, cols, np.ones(rows.size, np.float32), scene, samples
    )
    exposure = 0.6 * bench.sensor.full_well_e / open_rate.max()
    difference_e = (coarse - full) * exposure
    read = bench.sensor.read_noise_e
    assert np.sqrt(np.mean(difference_e**2)) < 0.05 * read
    noise_e = np.sqrt(full * exposure + read**2)
    assert np.abs(difference_e / noise_e).max() < 0.1


def test_camera_points_no_ray_reaches_get_no_light():
    """The family's fam19 images a 1920 x 1080 SLM 320 camera px right of centre: the
    camera's first 170 columns trace back past what the prism passes (no inverse) and
    must be dark, not NaN."""
    bench = truth(open_rig(rig_description_from_dict(family_rigs(45, 20)[19]))).bench
    rate = bench.renderer.render_dense(
        np.ones(bench.slm_shape, np.float32), bench.scene, bench.samples("laser:532")
    )
    assert np.isfinite(rate).all()
    assert rate[:, :170].max() == 0.0 and rate.max() > 0.0
