"""Synthetic but physically shaped calibration content for the bundle tests.

The models mimic the SASSI prototype: a 640 x 400 SLM relayed onto a 2048 x 2048 camera
(about 2.8 camera px per SLM px), an N-SF11 prism whose streak spans about 68 px over
400-700 nm (quadratic in the refractive index), a small vertical smile, 68 bins about one
camera pixel wide (about 2 nm wide in the blue, 10 nm in the red), a quadratic blur of 4 px at
405 and 635 nm and 1 px at 520 nm, and a mild perspective guide -> SLM homography.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from sassi_bench.bundle import (
    CalibrationModels,
    DispersionModel,
    QuadraticBlur,
    QualityCheck,
    WavelengthBins,
    publish,
)
from sassi_bench.optics.glass import sellmeier_index

SLM_SHAPE = (400, 640)
# N-SF11, SCHOTT catalog (B dimensionless, C in µm²).
SELLMEIER_B = (1.73759695, 0.313747346, 1.89878101)
SELLMEIER_C = (0.013188707, 0.0623068142, 155.23629)
LAMBDA_MIN, LAMBDA_MAX = 400.0, 700.0
N_BINS = 68

RIG: dict[str, Any] = {
    "name": "sim",
    "slm": {"shape": list(SLM_SHAPE), "contrast_eps": 0.002},
    "camera": {"shape": [2048, 2048], "read_noise_e": 5.0},
    "prism": {"glass": "N-SF11", "apex_deg": 30.0},
    "guide": {"shape": [540, 720]},
}

PROCEDURE: dict[str, Any] = {
    "lasers_nm": [450, 520, 532, 635, 670],
    "dispersion": {"field_degree": 3, "spectral_degree": 2},
    "blur": {"window_sigmas": 2.5},
}

GUIDE_TO_SLM = np.array(
    [[0.88, 0.02, -8.0], [-0.015, 0.75, -2.0], [2.0e-5, 1.0e-5, 1.0]], dtype=np.float64
)

# Coefficients of the 10 terms of legendre2d degree 3, ordered
# (0,0) (1,0) (0,1) (2,0) (1,1) (0,2) (3,0) (2,1) (1,2) (0,3).
X_COEFFS = np.array(
    [
        [1024.0, 895.0, 15.0, 2.0, -1.5, 0.8, 3.0, 0.0, 0.0, 0.5],  # relay + distortion
        [-35.0, -0.8, 0.3, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],  # spread ~68 px
        [1.2, 0.05, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ]
)
Y_COEFFS = np.array(
    [
        [1024.0, -10.0, 560.0, 0.0, 1.0, 1.5, 0.0, 0.4, 0.0, 0.0],
        [0.6, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],  # smile
        [0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    ]
)


def make_dispersion() -> DispersionModel:
    """The synthetic dispersion model (N-SF11, degree-3 field basis)."""
    n_blue, n_mid, n_red = sellmeier_index(
        [LAMBDA_MIN, 550.0, LAMBDA_MAX], SELLMEIER_B, SELLMEIER_C
    )
    return DispersionModel(
        glass="N-SF11",
        sellmeier_b=SELLMEIER_B,
        sellmeier_c=SELLMEIER_C,
        n_ref=float(n_mid),
        n_scale=float(n_blue - n_red) / 2.0,
        lambda_ref_nm=550.0,
        lambda_scale_nm=150.0,
        slm_shape=SLM_SHAPE,
        field_degree=3,
        x_coeffs=X_COEFFS,
        y_coeffs=Y_COEFFS,
    )


def make_bins(dispersion: DispersionModel, count: int = N_BINS) -> WavelengthBins:
    """Bins of equal camera width along the streak at the field centre."""
    lam = np.linspace(LAMBDA_MIN, LAMBDA_MAX, 4001)
    u0, v0 = (SLM_SHAPE[1] - 1) / 2, (SLM_SHAPE[0] - 1) / 2
    x, _ = dispersion.evaluate(u0, v0, lam)
    x_edges = np.linspace(x[0], x[-1], count + 1)
    edges = np.interp(x_edges, x, lam)
    centres = np.interp((x_edges[:-1] + x_edges[1:]) / 2, x, lam)
    return WavelengthBins(centres, edges, 1.2 * np.diff(edges))


def make_blur() -> QuadraticBlur:
    """4 px at 405 and 635 nm, 1 px at 520 nm."""
    return QuadraticBlur((1.0, 0.0, 3.0 / 1.15**2), 520.0, 100.0, 2.5)


def make_models(**overrides: Any) -> CalibrationModels:
    """Complete synthetic models; keyword arguments replace fields."""
    dispersion = make_dispersion()
    bins = make_bins(dispersion)
    fields: dict[str, Any] = {
        "dispersion": dispersion,
        "bins": bins,
        "blur": make_blur(),
        "guide_to_slm": GUIDE_TO_SLM,
        "guide_info": {"rms_px": 0.41, "matches": 812},
        "offset": {"method": "masked-cubic", "grid_step_px": 32, "mask_margin_px": 3},
        "response": 0.2 + 0.8 * np.exp(-(((bins.centres_nm - 560.0) / 120.0) ** 2)),
    }
    fields.update(overrides)
    return CalibrationModels(**fields)


def passing_quality() -> dict[str, Any]:
    return {
        "checks": [
            QualityCheck.at_most("dispersion_rms", 0.08, 0.25, "px"),
            QualityCheck.at_most("homography_rms", 0.41, 1.0, "px"),
            QualityCheck.at_least("macbeth_psnr", 33.0, 30.0, "dB"),
        ],
        "residuals": {"laser_x_rms_px": [0.07, 0.08, 0.09, 0.06, 0.1]},
        "leave_one_out": {"max_error_nm": 0.6},
    }


def failing_quality() -> dict[str, Any]:
    quality = passing_quality()
    quality["checks"][0] = QualityCheck.at_most("dispersion_rms", 0.9, 0.25, "px")
    return quality


def publish_synthetic(data: Path, **overrides: Any) -> Path:
    """Publish the synthetic models under ``data``; keyword arguments go to ``publish``."""
    kwargs: dict[str, Any] = {
        "rig": RIG,
        "quality": passing_quality(),
        "procedure": PROCEDURE,
        "inputs": [{"id": "laser-sweep-2024-05-01", "sha256": "ab" * 32}],
        "extra_arrays": {"laser_residuals_px": np.linspace(-0.1, 0.1, 25).reshape(5, 5)},
        "reports": {"summary.txt": "all good\n"},
        "data": data,
    }
    models = overrides.pop("models", None) or make_models()
    kwargs.update(overrides)
    return publish(models, **kwargs)


@pytest.fixture
def data_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """An empty data root; SASSI_BENCH_DATA is cleared so nothing touches calib_data/."""
    monkeypatch.delenv("SASSI_BENCH_DATA", raising=False)
    root = tmp_path / "data"
    root.mkdir()
    return root


@pytest.fixture
def published(data_root: Path) -> Path:
    """One published synthetic bundle (``<data_root>/sim/v0001``)."""
    return publish_synthetic(data_root)


# Captured at import: other folders' conftest modules may later take the name "conftest".
_THIS_MODULE = sys.modules[__name__]


@pytest.fixture(scope="session")
def synthetic() -> Any:
    """The helpers of this module, for tests (``synthetic.make_models()``...)."""
    return _THIS_MODULE
