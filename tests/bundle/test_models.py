"""The model contract: dispersion/blur evaluation against the documented formulas, validation."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.bundle import (
    BundleSchemaError,
    CalibrationModels,
    DispersionModel,
    QuadraticBlur,
    WavelengthBins,
)
from sassi_bench.bundle.blur import blur_from_manifest
from sassi_bench.optics.glass import sellmeier_index

# Closed forms of the first Legendre polynomials, independent of numpy.polynomial.
LEGENDRE = [
    lambda t: np.ones_like(t),
    lambda t: t,
    lambda t: (3 * t**2 - 1) / 2,
    lambda t: (5 * t**3 - 3 * t) / 2,
]
TERMS_DEGREE_3 = [(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2), (3, 0), (2, 1), (1, 2), (0, 3)]


def reference_xy(model: DispersionModel, u, v, lam):
    """Straightforward evaluation of the documented formulas (loops over terms only)."""
    height, width = model.slm_shape
    uh = 2 * np.asarray(u, float) / (width - 1) - 1
    vh = 2 * np.asarray(v, float) / (height - 1) - 1
    s_x = (sellmeier_index(lam, model.sellmeier_b, model.sellmeier_c) - model.n_ref) / model.n_scale
    s_y = (np.asarray(lam, float) - model.lambda_ref_nm) / model.lambda_scale_nm
    x = 0.0
    y = 0.0
    for k in range(3):
        for t, (i, j) in enumerate(TERMS_DEGREE_3):
            basis = LEGENDRE[i](uh) * LEGENDRE[j](vh)
            x = x + model.x_coeffs[k, t] * basis * s_x**k
            y = y + model.y_coeffs[k, t] * basis * s_y**k
    return x, y


def test_dispersion_evaluates_documented_formula(synthetic):
    model = synthetic.make_dispersion()
    rng = np.random.default_rng(1)
    u = rng.uniform(0, 639, 40)
    v = rng.uniform(0, 399, 40)
    lam = rng.uniform(400, 700, 40)
    x, y = model.evaluate(u, v, lam)
    x_ref, y_ref = reference_xy(model, u, v, lam)
    np.testing.assert_allclose(x, x_ref, rtol=0, atol=1e-9)
    np.testing.assert_allclose(y, y_ref, rtol=0, atol=1e-9)


def test_dispersion_broadcasts(synthetic):
    model = synthetic.make_dispersion()
    u = np.linspace(0, 639, 5)[:, None, None]
    v = np.linspace(0, 399, 4)[None, :, None]
    lam = np.linspace(400, 700, 11)[None, None, :]
    x, y = model.evaluate(u, v, lam)
    assert x.shape == y.shape == (5, 4, 11)
    assert x.dtype == np.float64
    x_ref, _ = reference_xy(model, *np.broadcast_arrays(u, v, lam))
    np.testing.assert_allclose(x, x_ref, atol=1e-9)
    x0, y0 = model.evaluate(320, 200, 550.0)
    assert np.ndim(x0) == 0 and np.ndim(y0) == 0


def test_synthetic_dispersion_is_physically_shaped(synthetic):
    model = synthetic.make_dispersion()
    x, _ = model.evaluate(319.5, 199.5, [400.0, 700.0])
    assert 64 < x[1] - x[0] < 72  # the prototype's ~68 px spread
    bins = synthetic.make_bins(model)
    widths = np.diff(bins.edges_nm)
    assert widths[0] < 3 and widths[-1] > 8  # ~2 nm in the blue, ~10 nm in the red


def test_blur_quadratic():
    blur = QuadraticBlur((1.0, 0.0, 3.0 / 1.15**2), 520.0, 100.0, 2.5)
    np.testing.assert_allclose(blur.sigma([405.0, 520.0, 635.0]), [4.0, 1.0, 4.0])
    np.testing.assert_allclose(blur.window_half_width(520.0), 2.5)


@pytest.mark.parametrize(
    ("field", "value", "match"),
    [
        ("x_coeffs", np.zeros((3, 9)), r"expected \(K, 10\)"),
        ("x_coeffs", np.full((3, 10), np.nan), "NaN"),
        ("x_coeffs", np.array([["a"] * 10] * 3), "real numeric"),
        ("n_scale", -1.0, "must be > 0"),
        ("slm_shape", (1, 640), "between 2"),
        ("field_degree", 2.5, "integer"),
        ("sellmeier_b", (1.0, 2.0), "3 numbers"),
    ],
)
def test_dispersion_rejects_malformed(synthetic, field, value, match):
    model = synthetic.make_dispersion()
    kwargs = {name: getattr(model, name) for name in DispersionModel.__dataclass_fields__}
    kwargs[field] = value
    with pytest.raises(BundleSchemaError, match=match):
        DispersionModel(**kwargs)


def test_bins_rejects_malformed():
    with pytest.raises(BundleSchemaError, match="strictly increasing"):
        WavelengthBins([450.0, 550.0], [400.0, 600.0, 500.0], [1.0, 1.0])
    with pytest.raises(BundleSchemaError, match="expected"):
        WavelengthBins([450.0, 550.0], [400.0, 500.0], [1.0, 1.0])
    with pytest.raises(BundleSchemaError, match="between their bin's edges"):
        WavelengthBins([450.0, 650.0], [400.0, 500.0, 600.0], [1.0, 1.0])


def test_models_reject_cross_model_problems(synthetic):
    with pytest.raises(BundleSchemaError, match="sigma must be > 0"):
        synthetic.make_models(blur=QuadraticBlur((-1.0, 0.0, 0.1), 520.0, 100.0, 2.5))
    with pytest.raises(BundleSchemaError, match=r"response.*expected \(68,\)"):
        synthetic.make_models(response=np.ones(5))
    with pytest.raises(BundleSchemaError, match="singular"):
        synthetic.make_models(guide_to_slm=np.zeros((3, 3)))
    disp = synthetic.make_dispersion()
    folded = disp.x_coeffs.copy()
    folded[2, 0] = 40.0  # strong curvature: the streak folds back on itself
    kwargs = {name: getattr(disp, name) for name in DispersionModel.__dataclass_fields__}
    kwargs["x_coeffs"] = folded
    with pytest.raises(BundleSchemaError, match="not monotonic"):
        synthetic.make_models(dispersion=DispersionModel(**kwargs))


def test_models_manifest_round_trip(synthetic):
    models = synthetic.make_models()
    section, arrays = models.to_manifest()
    again = CalibrationModels.from_manifest(section, arrays)
    np.testing.assert_array_equal(again.dispersion.x_coeffs, models.dispersion.x_coeffs)
    np.testing.assert_array_equal(again.guide_to_slm, models.guide_to_slm)
    assert again.guide_info["matches"] == 812
    assert again.offset["method"] == "masked-cubic"
    section["guide_homography"] = None
    del section["offset"]
    section["response"] = None
    bare = CalibrationModels.from_manifest(section, arrays)
    assert bare.guide_to_slm is None and bare.offset is None and bare.response is None


def _with_index_rows(disp: DispersionModel, y_index: np.ndarray) -> DispersionModel:
    kwargs = {name: getattr(disp, name) for name in DispersionModel.__dataclass_fields__}
    return DispersionModel(**{**kwargs, "y_index_coeffs": y_index})


def test_rows_in_the_index_are_evaluated_from_their_own_coefficients(synthetic):
    disp = synthetic.make_dispersion()
    y_index = np.zeros_like(disp.y_coeffs)
    y_index[0, 0], y_index[1, 0], y_index[2, 0] = 1000.0, 3.0, -0.5
    model = _with_index_rows(disp, y_index)
    assert model.row_in_index and not disp.row_in_index
    lam = np.array([405.0, 520.0, 690.0])
    s = (sellmeier_index(lam, disp.sellmeier_b, disp.sellmeier_c) - disp.n_ref) / disp.n_scale
    x, y = model.evaluate(319.5, 199.5, lam)  # the field centre: P_0 only
    np.testing.assert_allclose(y, 1000.0 + 3.0 * s - 0.5 * s**2, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(x, disp.evaluate(319.5, 199.5, lam)[0])
    # The paper's coefficients are kept, for readers of schema 1.0, and round trip.
    models = synthetic.make_models(dispersion=model)
    section, arrays = models.to_manifest()
    assert section["dispersion"]["y_index_coeffs"] in arrays
    again = CalibrationModels.from_manifest(section, arrays).dispersion
    np.testing.assert_array_equal(again.y_index_coeffs, y_index)
    np.testing.assert_array_equal(again.y_coeffs, disp.y_coeffs)
    with pytest.raises(BundleSchemaError, match="y_index_coeffs"):
        _with_index_rows(disp, y_index[:, :4])


def test_model_arrays_are_read_only(synthetic):
    models = synthetic.make_models()
    with pytest.raises(ValueError):
        models.dispersion.x_coeffs[0, 0] = 1.0
    with pytest.raises(TypeError):
        models.offset["method"] = "other"


def test_blur_psf_quadratic_adds_the_pixel_boxes_and_round_trips():
    blur = QuadraticBlur((0.5, 0.0, 2.0), 550.0, 150.0, 3.0, pixel_variance_px2=0.16)
    lam = np.array([400.0, 550.0, 700.0])
    psf = 0.5 + 2.0 * ((lam - 550.0) / 150.0) ** 2
    np.testing.assert_allclose(blur.sigma(lam), np.sqrt(psf**2 + 0.16))
    entry = blur.to_manifest()
    assert entry["model"] == "psf_quadratic" and entry["pixel_variance_px2"] == 0.16
    again = blur_from_manifest(entry)
    np.testing.assert_array_equal(again.sigma(lam), blur.sigma(lam))
    # A bundle of the plain quadratic reads and writes as before (no new key).
    plain = QuadraticBlur((1.0, 0.0, 3.0), 520.0, 115.0, 2.5).to_manifest()
    assert plain["model"] == "quadratic" and "pixel_variance_px2" not in plain
    assert blur_from_manifest(plain).pixel_variance_px2 == 0.0
    del entry["pixel_variance_px2"]
    with pytest.raises(BundleSchemaError, match="lacks pixel_variance_px2"):
        blur_from_manifest(entry)
    with pytest.raises(BundleSchemaError, match="must be >= 0"):
        QuadraticBlur((0.5, 0.0, 2.0), 550.0, 150.0, 3.0, pixel_variance_px2=-0.1)


def test_blur_states_its_error_when_the_fit_knows_it():
    stated = QuadraticBlur((0.5, 0.0, 2.0), 550.0, 150.0, 3.0, 0.16, relative_error=0.012)
    entry = stated.to_manifest()
    assert entry["relative_error"] == 0.012
    assert blur_from_manifest(entry).relative_error == 0.012
    del entry["relative_error"]  # a bundle from before the error was recorded
    assert blur_from_manifest(entry).relative_error is None
    assert "relative_error" not in QuadraticBlur((1.0, 0.0, 3.0), 520.0, 115.0, 2.5).to_manifest()
    for wrong in (-0.01, 1.0):
        with pytest.raises(BundleSchemaError, match="relative_error"):
            QuadraticBlur((0.5, 0.0, 2.0), 550.0, 150.0, 3.0, relative_error=wrong)
