"""The Macbeth validation on the virtual bench, scored against its ground truth."""

import dataclasses
import json
import re

import numpy as np
import pytest

from sassi_bench.commands import main
from sassi_bench.plots.screenshot import chromium_path, screenshot
from sassi_bench.rig.sim import truth
from sassi_bench.rig.sim.scenes import colorchecker_layout
from sassi_bench.validate.chart import validate_scans
from sassi_bench.validate.macbeth import patch_statistics, standard_error
from sassi_bench.validate.report import write_report


def _bin_average(values, grid, edges):
    """Mean of tabulated spectra (N, L) over each bin, like the reference's averaging."""
    fine = np.arange(edges[0], edges[-1] + 0.05, 0.1)
    dense = np.stack([np.interp(fine, grid, v) for v in values])
    idx = np.searchsorted(edges, fine, side="right") - 1
    idx = np.clip(idx, 0, len(edges) - 2)
    return np.stack([np.bincount(idx, weights=row) / np.bincount(idx) for row in dense])


@pytest.fixture(scope="module")
def good(chart_scan, patch_procedure):
    _, bundle, _, run = chart_scan
    return validate_scans(run.scan, bundle, patch_procedure)


def test_calibrated_bundle_meets_the_accuracy_targets(good):
    s = good.summary()
    assert good.passed, [c.describe() for c in good.checks if not c.passed]
    # On the default-noise scan, in the usable band: about twice what is measured (the
    # issue's targets: mean dE00 <= 1.0, max <= 2.5, mean spectral angle <= 2 degrees).
    assert s["mean_de00"] <= 0.2 and s["max_de00"] <= 0.75  # measured 0.106 and 0.377
    assert s["mean_spectral_angle_deg"] <= 1.4  # measured 0.735
    lo, hi = good.band_nm
    assert lo > 410 and hi > 680  # the LED's blue end is cut, the band is otherwise whole
    assert np.all(good.pixels > 200)


def test_noise_floor_sits_well_under_each_tolerance_and_is_honest(chart_scan, good):
    _, _, _, run = chart_scan
    floors = good.noise_floors()
    tolerance_checks = {c.name: c for c in good.checks if c.name != "noise_floor_fraction"}
    assert set(floors) == set(tolerance_checks)
    for name, floor in floors.items():
        assert 0 < floor <= 0.25 * tolerance_checks[name].tolerance, name
    (noise_check,) = [c for c in good.checks if c.name == "noise_floor_fraction"]
    assert noise_check.passed
    # The floor is the standard error of the patch means: two halves of every patch
    # (even and odd SLM columns, so different pinhole frames) must differ by what it
    # predicts (their difference has four times the variance of the full mean).
    scan = run.scan
    labels = good.grid.labels(scan.quality.shape, scan.origin, interior=0.5)
    columns = np.arange(scan.quality.shape[1])[None, :] + scan.origin[1]
    halves = [
        patch_statistics(scan.cube, scan.quality, np.where(columns % 2 == k, labels, -1))
        for k in (0, 1)
    ]
    whole = patch_statistics(scan.cube, scan.quality, labels)
    usable = good.usable
    diff = (halves[0].mean - halves[1].mean)[:, usable] / whole.mean[:, usable]
    predicted = 2 * standard_error(whole)[:, usable] / whole.mean[:, usable]
    ratio = np.sqrt(np.mean(diff**2)) / np.sqrt(np.mean(predicted**2))
    assert 0.6 < ratio < 1.6


def test_a_noisy_scan_fails_the_noise_check_and_says_why(chart_scan, patch_procedure, good):
    _, bundle, _, run = chart_scan
    rng = np.random.default_rng(1)
    cube = run.scan.cube
    scale = np.percentile(np.abs(cube), 99, axis=(0, 1))
    noisy = cube + (1.5 * scale * rng.standard_normal(cube.shape)).astype(np.float32)
    # So much noise hides the chart from the detector: place it by its corners.
    corners = good.grid.centres()[[0, 5, 23, 18]]
    result = validate_scans(
        dataclasses.replace(run.scan, cube=noisy), bundle, patch_procedure, corners=corners
    )
    (noise_check,) = [c for c in result.checks if c.name == "noise_floor_fraction"]
    assert not noise_check.passed and not result.passed
    assert noise_check.value > 4 * good.checks[-1].value
    assert any("too noisy to judge the calibration" in n for n in result.notes)


def test_measured_reflectance_matches_the_scene(chart_scan, good):
    rig, _, _, _ = chart_scan
    cube, grid = truth(rig).scene_cube("colorchecker")
    labels = good.grid.labels(cube.shape[:2], interior=0.5)
    true = np.stack([cube[labels == k].mean(axis=0) for k in range(24)])
    true_bins = _bin_average(true, grid, good.bin_edges_nm)
    diff = np.abs(good.reflectance - true_bins)[:, good.usable]
    # Measured 0.0041 (0.0036 with the separable row unmixing: on this test calibration's
    # bundle the mixed unmixing costs the patches a little; on the full chain's it gains,
    # the red patch 0.0051 -> 0.0032 in benchmarks/accuracy_table.py).
    assert np.sqrt(np.mean(diff**2)) < 0.0045
    # The worst is the last bin (~697 nm: 10 nm wide, blur sigma 3.5 px) of a steep red
    # edge, where the within-streak unmixing's smoothness prior is strongest (0.04).
    assert diff.max() < 0.05
    # The detector's patch centres against the scene layout.
    lay = colorchecker_layout(rig.slm.shape, 0, rig.description.scenes.colorchecker_rotation_deg)
    centre = good.grid.centres().mean(axis=0)
    assert np.hypot(centre[0] - lay["centre_col"], centre[1] - lay["centre_row"]) < 0.5


def test_diffuser_white_reference_agrees(chart_scan, thin_white_scan, procedure, good):
    _, bundle, _, run = chart_scan
    result = validate_scans(run.scan, bundle, procedure, white=thin_white_scan)
    assert result.passed
    assert result.settings["white_reference"] == "diffuser"
    # Two white references, one chart: the same reflectances within the noise.
    both = result.usable
    assert np.abs(result.reflectance - good.reflectance)[:, both].mean() < 0.005
    assert result.summary()["mean_de00"] <= 1.0


def test_manual_corners_reproduce_the_detection(chart_scan, patch_procedure, good):
    _, bundle, _, run = chart_scan
    corners = good.grid.centres()[[0, 5, 23, 18]] + 0.3  # clicks are a little off
    manual = validate_scans(run.scan, bundle, patch_procedure, corners=corners)
    assert manual.grid.method == "corners"
    assert np.abs(manual.de00 - good.de00).max() < 0.1


def test_a_wavelength_map_shifted_by_one_pixel_fails(chart_scan, shifted_bundle, tmp_path):
    _, _, data, run = chart_scan
    out = tmp_path / "report"
    status = main(
        [
            "validate", "macbeth", "--rig", "sim", "--bundle", str(shifted_bundle.path),
            "--data", str(data), "--session", run.session.id, "--white", "patch",
            "--out", str(out), "--quiet",
        ]
    )  # fmt: skip
    assert status == 1
    doc = json.loads((out / "macbeth_report.json").read_text())
    assert doc["passed"] is False
    assert doc["summary"]["mean_de00"] > 1.0
    failed = {c["name"] for c in doc["checks"] if not c["passed"]}
    assert {"mean_de00", "max_de00"} <= failed
    assert "FAIL" in (out / "macbeth_report.html").read_text()


def test_report_is_self_contained_and_renders(chart_scan, good, patch_procedure, tmp_path):
    _, bundle, _, _ = chart_scan
    html, data = write_report(good, bundle, patch_procedure, tmp_path)
    text = html.read_text()
    assert text.count("data:image/png;base64,") == 6
    assert 'src="http' not in text and "<link" not in text  # nothing to fetch
    assert "usable band" in text
    doc = json.loads(data.read_text())
    assert set(doc["figures"]) == {
        "band_error", "spectra", "de00", "chart", "localisation", "wavelength_calibration"
    }  # fmt: skip
    # Where the worst patch's error lies (every patch passes here), in a sentence and drawn.
    assert len(doc["band_errors"]) == 1 and not doc["band_errors"][0]["failed"]
    assert doc["band_errors"][0]["patch"] == int(np.argmax(good.rmse)) + 1
    # Far from every tolerance, the report says what "worst" means and gives no advice.
    sentence = doc["band_errors"][0]["sentence"]
    assert not doc["band_errors"][0]["close"]
    assert "largest reflectance RMSE" in sentence and "recalibrate" not in sentence
    # Tolerances are printed as set (a derived one to three digits), and the picture the
    # patches were found on says what it is.
    assert not re.search(r"&lt;= \d+\.\d{4,}", text)
    assert "raw radiance under the LED" in text
    assert "Where the error lies" in text and doc["band_errors"][0]["name"] in text
    assert len(doc["figures"]["spectra"]["measured"]) == 24
    assert doc["figures"]["de00"]["de00"] == pytest.approx(good.de00.tolist())
    if chromium_path() is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium)")
    import cv2

    png = screenshot(html, tmp_path / "report.png", width=1400, height=4200)
    image = cv2.imread(str(png))
    assert image.shape[:2] == (4200, 1400)
    # What a person sees first: the green PASS badge near the top left.
    top = image[:200, :400].reshape(-1, 3).astype(int)
    green = (np.abs(top - [0x32, 0x7D, 0x2E]) < 12).all(axis=1)  # BGR of #2e7d32
    assert green.sum() > 500
    # The page is not blank further down: the embedded plots rendered.
    assert (image[600:3500] < 200).any(axis=2).mean() > 0.05
    # It fits a 1200 px wide window and a narrow one: no horizontal scrolling.
    assert _overflow_px(html, tmp_path, 1200) == 0
    assert _overflow_px(html, tmp_path, 800) == 0


def _overflow_px(html, tmp_path, width: int) -> int:
    """How far the page runs past a ``width`` px window, measured in headless Chromium."""
    import subprocess

    probe = tmp_path / f"overflow-{width}.html"
    measure = (
        '<script>addEventListener("load", () => document.body.setAttribute("data-overflow", '
        "document.documentElement.scrollWidth - document.documentElement.clientWidth));</script>"
    )
    probe.write_text(html.read_text().replace("</body>", measure + "</body>"))
    dom = subprocess.run(
        [chromium_path(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         f"--window-size={width},900", "--dump-dom", probe.as_uri()],
        capture_output=True, text=True, timeout=120,
    ).stdout  # fmt: skip
    return int(re.search(r'data-overflow="(-?\d+)"', dom).group(1))


def test_guide_image_warped_to_the_slm_locates_the_chart(calibrated_sim, tmp_path):
    import dataclasses

    from sassi_bench.bundle import load, publish
    from sassi_bench.validate.chart import reference_rgb
    from sassi_bench.validate.locate import detect_chart
    from sassi_bench.validate.reference import reference_chart
    from sassi_bench.workflows.macbeth import guide_picture

    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    with pytest.raises(ValueError, match="no guide -> SLM homography"):
        guide_picture(rig, bundle, "led")
    # A bundle carrying the bench's own homography (the guide calibration's ideal result).
    models = dataclasses.replace(bundle.models, guide_to_slm=truth(rig).guide_to_slm)
    path = publish(
        models, rig=rig.description, quality={"checks": [], "residuals": {}}, procedure={},
        data=tmp_path,
    )  # fmt: skip
    rig.set_scene("colorchecker")
    picture = guide_picture(rig, load(path), "led")
    grid = detect_chart(picture, reference_rgb(reference_chart()))
    lay = colorchecker_layout(rig.slm.shape, 0, rig.description.scenes.colorchecker_rotation_deg)
    centre = grid.centres().mean(axis=0)
    assert np.hypot(centre[0] - lay["centre_col"], centre[1] - lay["centre_row"]) < 0.5
