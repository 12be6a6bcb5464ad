"""The spectral calibration on a rig described as an optical design (the singlet arm:
strong chromatic, field-dependent and elliptical spots), scored against the bench's truth.

The lamp pinholes sit 160 SLM px apart: the design's streaks are 125 px long (the shipped
procedure's 100 px pitch is made for ``sim``'s 68 px streaks and is refused here).
"""

import numpy as np
import pytest

from sassi_bench.procedure import load_procedure
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.spectral import run_spectral_calibration


@pytest.fixture(scope="module")
def calibrated(design_rigs, tmp_path_factory):
    rig = design_rigs("singlet")
    procedure = load_procedure("spectral_calibration")
    procedure["lamps"]["pinhole_pitch_px"] = [160, 24]
    data = tmp_path_factory.mktemp("data-singlet")
    result = run_spectral_calibration(
        rig, procedure, data=data, progress=False, session_id="acc", allow_failed=True
    )
    return rig, result


def test_positions_and_wavelengths_hold_on_real_optics(calibrated):
    rig, result = calibrated
    t = truth(rig)
    worst = 0.0
    for d in result.lasers:
        x, y = t.slm_to_camera(d.slm_u, d.slm_v, t.laser_centre_nm(d.wavelength_nm))
        worst = max(worst, float(np.sqrt(np.mean((x - d.camera_x) ** 2 + (y - d.camera_y) ** 2))))
    error_nm = t.wavelength_map_error_nm(result.dispersion.model)
    rms = float(np.sqrt(np.mean(error_nm**2)))
    print(f"correspondences worst laser RMS {worst:.3f} px; wavelength map RMS {rms:.3f} nm")
    # measured: correspondences 0.053 px (the target 0.05), map 0.036 nm RMS
    assert worst < 0.10
    assert rms < 0.07


def test_the_field_blur_follows_the_spot_between_the_lasers(calibrated):
    rig, result = calibrated
    t = truth(rig)
    model = result.blur.model
    assert model.kind == "field_covariance"
    h, w = rig.slm.shape
    u, v = np.meshgrid(np.linspace(0, w - 1, 9), np.linspace(0, h - 1, 5))
    u, v = u.ravel()[:, None], v.ravel()[:, None]
    lam = np.linspace(450.0, 670.0, 23)[None, :]
    cxx, cyy, _ = t.spot_covariance(u, v, lam)
    spot = model.spot(u, v, lam)
    along = np.abs(np.sqrt(spot.along**2 + 1 / 12) - np.sqrt(cxx)).max()
    across = np.abs(np.sqrt(spot.across**2 + 1 / 12) - np.sqrt(cyy)).max()
    print(f"blur over the field, 450-670 nm: along {along:.3f} px, across {across:.3f} px")
    # measured: along 0.051 px, across 0.038 px (the target 0.1 px; the widest
    # round spot misses by 0.96 px). With the blur pinholes 20 SLM px short of the edges
    # it was 0.27 / 0.12 px: the fit extrapolated the pinholes' noise to the field's edges.
    assert along < 0.08
    assert across < 0.06
