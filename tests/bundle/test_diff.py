"""bundle diff reports changes in camera px, nm and SLM px."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sassi_bench.bundle import (
    DispersionModel,
    QuadraticBlur,
    QualityCheck,
    diff_bundles,
    format_diff,
    load,
)


def test_identical_bundles_have_no_difference(data_root: Path, synthetic):
    a = load(synthetic.publish_synthetic(data_root))
    b = load(synthetic.publish_synthetic(data_root))
    d = diff_bundles(a, b)
    assert d.map_shift_px.max == 0 and d.map_shift_nm.max == pytest.approx(0, abs=1e-9)
    assert d.homography == "unchanged" and d.blur_sigma_px.max == 0
    assert d.procedure == [] and d.quality == []
    text = format_diff(d)
    assert "procedure parameters: unchanged" in text and "quality checks: unchanged" in text


def test_changes_are_measured_in_scientist_units(data_root: Path, synthetic):
    a = load(synthetic.publish_synthetic(data_root))
    disp = synthetic.make_dispersion()
    kwargs = {name: getattr(disp, name) for name in DispersionModel.__dataclass_fields__}
    shifted = disp.x_coeffs.copy()
    shifted[0, 0] += 0.5  # every streak moves 0.5 camera px to the right
    kwargs["x_coeffs"] = shifted
    translate = np.array([[1.0, 0, 1.0], [0, 1.0, 0], [0, 0, 1.0]])  # +1 SLM px in u
    models = synthetic.make_models(
        dispersion=DispersionModel(**kwargs),
        blur=QuadraticBlur((1.1, 0.0, 3.0 / 1.15**2), 520.0, 100.0, 2.5),
        guide_to_slm=translate @ synthetic.GUIDE_TO_SLM,
    )
    quality = synthetic.passing_quality()
    quality["checks"][0] = QualityCheck.at_most("dispersion_rms", 0.11, 0.25, "px")
    procedure = {**synthetic.PROCEDURE, "blur": {"window_sigmas": 3.0}}
    b = load(
        synthetic.publish_synthetic(data_root, models=models, quality=quality, procedure=procedure)
    )
    d = diff_bundles(a, b, grid=5)
    assert d.map_shift_px.max == pytest.approx(0.5, abs=1e-9)
    assert d.map_shift_y_px.max == 0
    # At fixed camera x, the wavelength moves by 0.5 px / (dx/dλ), largest in the red.
    u, v = np.meshgrid(np.linspace(0, 639, 5), np.linspace(0, 399, 5))
    lam = a.wavelengths
    x_hi, _ = a.slm_to_camera(u.ravel()[:, None], v.ravel()[:, None], lam + 0.01)
    x_lo, _ = a.slm_to_camera(u.ravel()[:, None], v.ravel()[:, None], lam - 0.01)
    slope = (x_hi - x_lo) / 0.02
    assert d.map_shift_nm.max == pytest.approx(np.max(0.5 / slope), rel=0.02)
    assert d.homography == "changed"
    assert d.homography_shift_px.max == pytest.approx(1.0, abs=1e-6)
    assert d.blur_sigma_px.max == pytest.approx(0.1)
    assert d.procedure == [("blur.window_sigmas", 2.5, 3.0)]
    assert d.quality == [("dispersion_rms", "0.08 px PASS", "0.11 px PASS")]
    text = format_diff(d)
    assert "shift max 0.5 px" in text and "SLM points move max 1 px" in text
    assert "blur.window_sigmas: 2.5 -> 3.0" in text


def test_homography_added_or_removed(data_root: Path, synthetic):
    a = load(
        synthetic.publish_synthetic(data_root, models=synthetic.make_models(guide_to_slm=None))
    )
    b = load(synthetic.publish_synthetic(data_root))
    assert diff_bundles(a, b).homography == "added"
    assert diff_bundles(b, a).homography == "removed"
