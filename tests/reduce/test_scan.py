"""Pinhole scans on the virtual bench, assembled with a calibrated bundle."""

import numpy as np
import pytest
import xarray as xr

from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.reduce.scan import ScanRun, assemble_scan
from sassi_bench.rig.sim import truth
from sassi_bench.spectra.cells import NEGLIGIBLE_COUPLING
from sassi_bench.spectra.cube_io import write_envi, write_netcdf
from sassi_bench.spectra.scan import QUALITY_FLAGS, ScanAssembly


def _thinned(plan: Plan, every: int) -> Plan:
    keep = [s for i, s in enumerate(plan.steps) if s.tags["role"] == "closed" or i % every == 1]
    return Plan(plan.name, tuple(keep), plan.parameters)


@pytest.fixture(scope="module")
def white_scan(calibrated_sim, tmp_path_factory):
    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    plan = _thinned(scan_plan(rig.slm.shape, "led", 0.1, scene="white"), every=10)
    session = Session.create(rig.description, plan, session_id="white-scan", data=data)
    run_plan(rig, plan, session, progress=False)
    return rig, bundle, session, assemble_scan(session, bundle, progress=False)


def test_background_matches_the_closed_pixel_leak(white_scan):
    rig, _, _, scan = white_scan
    bench = truth(rig).bench
    exposure = 0.1
    electrons = (bench._background_rate() + bench.sensor.dark_current_e_per_s) * exposure
    true_background = electrons / bench.sensor.gain_e_per_adu + bench.sensor.dark_offset_adu
    # Estimated on the camera rows that streaks reach (NaN elsewhere: not needed).
    estimated = np.isfinite(scan.background)
    assert estimated.mean() > 0.8
    error = np.sqrt(np.mean((scan.background - true_background)[estimated] ** 2))
    # Issue target: offset residual <= 1 % of the mean streak signal; measured 0.0115 %.
    assert error <= 2.3e-4 * scan.mean_streak_signal
    assert (
        scan.background_check_rms is not None
        and scan.background_check_rms < 0.05 * scan.mean_streak_signal
    )


def test_white_spectra_are_uniform_and_unmeasured_pixels_flagged(white_scan):
    rig, bundle, session, scan = white_scan
    measured = scan.quality == 0
    opened = sum(
        int(np.count_nonzero(render_pattern(step.pattern, rig.slm.shape)))
        for step in session.plan.steps
        if step.tags["role"] == "pinholes"
    )
    assert measured.sum() == opened
    assert np.all(scan.quality[~measured] == QUALITY_FLAGS["not_measured"])
    spectra = scan.cube[measured]
    band = (bundle.wavelengths > 450) & (bundle.wavelengths < 680)
    spread = spectra[:, band].std(axis=0) / spectra[:, band].mean(axis=0)
    assert np.median(spread) < 0.0085  # measured 0.0042


def test_cube_is_written_as_netcdf_and_envi(white_scan, tmp_path):
    _, bundle, session, scan = white_scan
    ds = ScanRun(scan, False, session, bundle).dataset()
    path = write_netcdf(ds, tmp_path / "cube.nc")
    back = xr.open_dataset(path)
    assert back["radiance"].dims == ("y", "x", "wavelength")
    assert back.attrs["bundle_version"] == bundle.version
    assert back.attrs["session_id"] == "white-scan"
    assert np.allclose(back["wavelength"].values, bundle.wavelengths)
    back.close()
    with pytest.raises(Exception, match="exists"):
        write_netcdf(ds, path)
    header = write_envi(ds, tmp_path / "cube")
    text = header.read_text()
    assert "wavelength = {" in text and "fwhm = {" in text and "default bands" in text


def test_saturated_streaks_are_reported_by_frame_and_pixel(calibrated_sim):
    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    plan = _thinned(scan_plan(rig.slm.shape, "led", 3.0, scene="white"), every=250)
    session = Session.create(rig.description, plan, session_id="saturated-scan", data=data)
    run_plan(rig, plan, session, progress=False)
    scan = assemble_scan(session, bundle, progress=False)
    assert (scan.quality & QUALITY_FLAGS["saturated"]).any()
    assert any("saturated" in line and "SLM pixel (u=" in line for line in scan.problems)


def test_a_scan_killed_midway_resumes_to_the_same_cube(calibrated_sim):
    from sassi_bench import open_rig

    _, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    rig = open_rig("sim")
    plan = _thinned(scan_plan(rig.slm.shape, "led", 0.1, scene="colorchecker"), every=50)
    whole = Session.create(rig.description, plan, session_id="whole", data=data)
    run_plan(rig, plan, whole, progress=False)
    killed = Session.create(rig.description, plan, session_id="killed", data=data)
    run_plan(open_rig("sim"), plan, killed, progress=False, stop_after=4)
    assert not killed.is_complete
    resumed = Session.open("killed", data=data)
    run_plan(open_rig("sim"), plan, resumed, progress=False)
    a = assemble_scan(whole, bundle, progress=False)
    b = assemble_scan(resumed, bundle, progress=False)
    np.testing.assert_array_equal(a.cube, b.cube)
    np.testing.assert_array_equal(a.quality, b.quality)


def test_an_roi_cube_is_the_full_cubes_region(white_scan):
    _, bundle, session, scan = white_scan
    roi, region = (100, 200, 180, 330), (slice(100, 180), slice(200, 330))
    part = assemble_scan(session, bundle, roi=roi, deblur=False, progress=False, workers=1)
    whole = assemble_scan(session, bundle, deblur=False, progress=False)
    assert part.origin == (100, 200) and part.cube.shape[:2] == (80, 130)
    assert np.array_equal(part.quality, scan.quality[region])
    good = part.quality == 0
    full = whole.cube[region][good]
    # The ROI's edge rows are unmixed with their neighbours outside it, as in the full cube;
    # which couplings fall under the floor is decided per frame, hence the tolerance.
    assert np.abs(part.cube[good] - full).max() <= NEGLIGIBLE_COUPLING * np.abs(full).max()
    assert np.array_equal(part.background, scan.background, equal_nan=True)
    # The deblur's regularisation is chosen once per session, from whole frames whatever the
    # ROI (measured on the ColorChecker scan: 1.0e-6 of the peak after the deblur, 6.3e-6
    # before); chosen from the pixels assembled, it differed by up to 2.4 % of the peak.
    deblurred = assemble_scan(session, bundle, roi=roi, progress=False, workers=1)
    assert deblurred.deblur == scan.deblur
    assert np.array_equal(deblurred.mean_spectrum, scan.mean_spectrum)
    reference = scan.cube[region][good]
    assert (
        np.abs(deblurred.cube[good] - reference).max()
        <= NEGLIGIBLE_COUPLING * np.abs(reference).max()
    )
    with pytest.raises(ValueError, match=r"scan assembly.*ROI"):
        assemble_scan(session, bundle, roi=(100, 200, 90, 330), progress=False)


def test_mixed_blur_unmixing_brings_the_red_end_closer_to_the_truth(white_scan):
    rig, bundle, session, mixed = white_scan  # the mixed unmixing is the default
    separable = assemble_scan(session, bundle, unmixing="separable", progress=False)
    expected = truth(rig).binned_cube(bundle.bin_edges, "led", "white")
    red = bundle.wavelengths > 650

    def red_error(cube):
        good = mixed.quality == 0
        a, b = cube[good].astype(np.float64), expected[good]
        gain = (a * b).sum() / (b * b).sum()
        return np.sqrt(((a - gain * b)[:, red] ** 2).mean()) / (gain * b).max()

    # A white scene stacks equal spectra, so the separable model is off only by the
    # blurs' mixture in each column: 0.96 % -> 0.93 % of the peak beyond 650 nm.
    assert red_error(mixed.cube) < red_error(separable.cube)


def test_a_few_offsets_leave_the_blue_end_of_the_white_true(calibrated_sim):
    """The response's plan (4 x 5 offsets) under halogen: a third of the camera is never
    free of streaks, and under a streak's blue end the background is 10-25 times its own
    light, so the background there must be the closed frame's and no other streak's tail.
    The column sums, averaged per field point, against the forward model applied to the
    bench's light: 1.3-3.6 % under it at 401-407 nm before, within 0.25 % in every bin now."""
    from sassi_bench.spectra.forward import StreakForwardModel

    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    full = scan_plan(rig.slm.shape, "halogen", 0.1, scene="white")
    keep = tuple(s for s in full.steps if s.tags["role"] == "closed" or s.tags["ox"] % 25 == 0)
    plan = Plan(full.name, keep, full.parameters)
    session = Session.create(rig.description, plan, session_id="white-few-offsets", data=data)
    run_plan(rig, plan, session, progress=False)
    scan = assemble_scan(session, bundle, keep_raw=True, deblur=False, progress=False)

    model = StreakForwardModel.from_bundle(bundle)
    rows, cols = np.nonzero(scan.quality == 0)
    points = model.point(rows, cols)
    t = truth(rig)
    grid, step = t.wavelengths_nm, np.gradient(t.wavelengths_nm)
    photons = t.light_samples("halogen").weights * t.quantum_efficiency(grid)
    misfit = []
    for p in np.unique(points):
        mean = scan.column_sums[rows[points == p], cols[points == p]].astype(float).mean(0)
        lam = model.wavelengths_nm[p]
        mid = 0.5 * (lam[1:] + lam[:-1])
        edges = np.r_[2 * lam[0] - mid[0], mid, 2 * lam[-1] - mid[-1]]
        edges[model.guard : model.n_bins - model.guard + 1] = bundle.bin_edges
        overlap = np.minimum(grid + step / 2, edges[1:, None]) - np.maximum(
            grid - step / 2, edges[:-1, None]
        )
        predicted = model.spill[p] @ (np.clip(overlap, 0, None) / step * photons).sum(1)
        core = np.arange(model.guard, model.n_bins - model.guard)
        mid_band = core[(bundle.wavelengths > 450) & (bundle.wavelengths < 600)]
        gain = (mean[mid_band] @ predicted[mid_band]) / (predicted[mid_band] @ predicted[mid_band])
        misfit.append(mean[core] / (gain * predicted[core]) - 1)
    misfit = np.median(misfit, axis=0)
    blue = bundle.wavelengths < 410
    assert np.abs(misfit[blue]).max() < 0.005, np.round(100 * misfit[blue], 2)  # 0.0032
    assert np.abs(misfit[~blue]).max() < 0.0045, np.round(100 * misfit[~blue], 2)  # 0.0022


def test_a_closed_frame_of_the_wrong_shape_is_reported_and_left_out(white_scan):
    _, bundle, session, _ = white_scan
    assembly = ScanAssembly(session.plan, session.rig, bundle, deblur=False)
    for index in assembly.steps:
        frame = session.read_frame(index)
        assembly.read(index, frame[:-1] if index == assembly.closed_step else frame)
    scan = assembly.finish(progress=False)
    assert scan.background_check_rms is None
    assert any("closed SLM" in line and "without it" in line for line in scan.problems)
    assert np.isfinite(scan.cube[scan.quality == 0]).all()
