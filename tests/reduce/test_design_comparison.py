"""As designed against as built: the measured maps of a design rig against its described
design, and the diagnosis of a bench built off it.

The "measured" maps here are the bench's own optics (a design changed the way a rig's
``as_built`` section changes it, traced on the comparison grid, or the virtual bench's
truth), with noise at the level a calibration measures them to; the code under test sees
only the design as described. The chain itself (a calibration's models compared, the
note, the quality section and the figure of its bundle) is checked on sim-singlet in
``tests/workflows/test_design_calibration.py``, where the calibration already runs.
"""

from types import SimpleNamespace

import numpy as np
import pytest

from sassi_bench.optics.design import with_override
from sassi_bench.reduce.design_comparison import (
    Candidate,
    DesignComparison,
    Diagnosis,
    FieldMaps,
    compare_with_design,
    comparison_grid,
    comparison_of_models,
    design_maps,
)
from sassi_bench.rig.config import load_rig_description

pytestmark = [
    pytest.mark.filterwarnings("ignore::DeprecationWarning"),
    pytest.mark.filterwarnings("ignore::UserWarning"),
]

#: The band the shipped rigs' lasers span (where the calibration measures the spot).
BAND_NM = (450.0, 670.0)
#: What a calibration of sim-achromat built to its design measured against the design:
#: positions 0.05 px RMS, spot widths 0.03 px RMS.
POSITION_NOISE_PX = 0.05
WIDTH_NOISE_PX = 0.03


def _design(name):
    pytest.importorskip("optiland", reason='pip install "sassi-bench[design]"')
    desc = load_rig_description(f"sim-{name}")
    shapes = (
        (desc.slm.height, desc.slm.width),
        (desc.spectral_camera.height, desc.spectral_camera.width),
    )
    return desc.design, comparison_grid(*shapes, BAND_NM)


def _noisy(maps: FieldMaps, seed: int) -> FieldMaps:
    """Maps as a calibration measures them: positions and widths with its noise."""
    rng = np.random.default_rng(seed)
    along = maps.width_along + rng.normal(0, WIDTH_NOISE_PX, maps.x.shape)
    across = maps.width_across + rng.normal(0, WIDTH_NOISE_PX, maps.x.shape)
    rho = maps.cxy / np.sqrt(maps.cxx * maps.cyy)
    return FieldMaps(
        maps.u,
        maps.v,
        maps.wavelengths_nm,
        maps.x + rng.normal(0, POSITION_NOISE_PX, maps.x.shape),
        maps.y + rng.normal(0, POSITION_NOISE_PX, maps.y.shape),
        along**2,
        across**2,
        rho * along * across,
    )


def _as_built(design, spec, as_built_design, seed=1):
    """The maps of a bench whose ``as_built: {design: ...}`` is ``as_built_design``."""
    built = with_override(design, as_built_design, "as_built.design")
    return _noisy(design_maps(built, spec), seed)


def test_a_bench_built_to_its_design_matches_it():
    design, spec = _design("achromat")
    found = compare_with_design(design, _noisy(design_maps(design, spec), 0), spec)
    assert found.matches
    assert found.diagnoses == () and found.best is None
    assert found.verdict.startswith("The bench matches its design")
    # measured: 0.070 and 0.030 px (the noise put in)
    assert found.position_rms_px < 0.1 and found.width_rms_px < 0.06


# (as_built surfaces, the candidate it is, its amount in the candidate's unit, tolerance)
ACHROMAT_CASES = {
    "decentred camera lens": (
        {8: {"decenter_mm": [0.0, 0.04]}, 9: {"decenter_mm": [0.0, 0.04]},
         10: {"decenter_mm": [0.0, 0.04]}},
        "camera lens (surfaces 8-10) decentred in y", 0.04, 0.1,
    ),
    "defocused camera": (
        {10: {"thickness_mm": 13.6249 + 0.06}}, "camera off focus", 0.06, 0.2,
    ),
}  # fmt: skip


@pytest.mark.parametrize("case", sorted(ACHROMAT_CASES))
def test_the_diagnosis_names_the_misalignment_and_its_size(case):
    design, spec = _design("achromat")
    surfaces, name, amount, tolerance = ACHROMAT_CASES[case]
    found = compare_with_design(design, _as_built(design, spec, {"surfaces": surfaces}), spec)
    assert not found.matches
    assert found.best is not None, found.verdict
    # named, alone or beside what the maps cannot tell it from (the camera shifted)
    named = {d.candidate.name: d for d in found.named}
    assert name in named, found.verdict
    assert name in found.verdict
    # measured: the camera lens 40.0 um for 40 (explains 99.99 %), the focus 60.3 um for
    # 60 (explains 92.6 %: the rest is the widths' noise)
    assert named[name].amount == pytest.approx(amount, rel=tolerance)
    assert named[name].explained > 0.85


def test_a_camera_shifted_is_named_beside_the_lens_that_moves_the_image_alike():
    design, spec = _design("achromat")
    found = compare_with_design(
        design, _as_built(design, spec, {"image": {"decenter_mm": [0.28215, 0.05]}}), spec
    )
    named = {d.candidate.name: d.amount for d in found.named}
    # measured: camera +50.0 um and the camera lens -50.8 um, each explaining 99.99 %
    assert named["camera shifted in y"] == pytest.approx(0.05, rel=0.1)
    assert "camera lens (surfaces 8-10) decentred in y" in named
    assert "cannot tell them apart" in found.verdict


def test_a_rolled_prism_is_named_with_its_roll():
    design, spec = _design("achromat")
    # the prism turned 1.5 degrees about the axis, as a lab's as_built writes it: each
    # face's tilt turned about z before its own (x, y, z) tilts, in those tilts' convention
    rolled = {
        "surfaces": {
            5: {"tilt_deg": [-0.7847, 27.6084, 1.6928]},
            6: {"tilt_deg": [0.0624, -2.3805, 1.5013]},
        }
    }
    found = compare_with_design(design, _as_built(design, spec, rolled), spec)
    assert found.best is not None, found.verdict
    assert found.best.candidate.name == "prism (surfaces 5-6) rolled"
    assert found.best.amount == pytest.approx(1.5, rel=0.2)  # measured: 1.50 deg (explains 99 %)


def test_a_decentred_singlet_is_named():
    design, spec = _design("singlet")
    surfaces = {7: {"decenter_mm": [0.03, 0.0]}, 8: {"decenter_mm": [0.03, 0.0]}}
    found = compare_with_design(design, _as_built(design, spec, {"surfaces": surfaces}), spec)
    named = {d.candidate.name: d for d in found.named}
    lens = named["camera lens (surfaces 7-8) decentred in x"]
    assert lens.amount == pytest.approx(0.03, rel=0.1)  # measured: 30.0 um


def test_the_virtual_bench_built_off_its_design_is_diagnosed_from_its_optics(design_rigs):
    """The bench's own optics (its truth, traced from the rig's as_built section) against
    the description: what a perfect calibration of that bench would publish."""
    from sassi_bench import open_rig
    from sassi_bench.rig.config import rig_description_from_dict
    from sassi_bench.rig.sim import truth

    data = load_rig_description("sim-singlet").to_dict()
    data["as_built"] = {"design": {"surfaces": {8: {"thickness_mm": 13.2109 - 0.05}}}}
    desc = rig_description_from_dict(data)
    rig = open_rig(desc)
    design, spec = _design("singlet")
    nominal = design_maps(design, spec)

    relay = truth(rig).bench.relay

    def spot(u, v, lam):
        cxx, cyy, cxy = relay.optics_covariance(u, v, lam)
        return SimpleNamespace(
            along=np.sqrt(cxx), across=np.sqrt(cyy), correlation=cxy / np.sqrt(cxx * cyy)
        )

    # the bench's optics where a bundle's models would be (no SLM pixel inside the spot)
    models = SimpleNamespace(
        dispersion=SimpleNamespace(evaluate=relay.forward), blur=SimpleNamespace(spot=spot)
    )
    shapes = (
        (desc.slm.height, desc.slm.width),
        (desc.spectral_camera.height, desc.spectral_camera.width),
    )
    found = comparison_of_models(design, models, *shapes, BAND_NM)
    np.testing.assert_allclose(found.design.u, nominal.u)
    assert found.best is not None, found.verdict
    assert found.best.candidate.name == "camera off focus"
    assert found.best.amount == pytest.approx(-0.05, rel=0.2)  # measured: -49.98 um


def test_the_comparison_reads_as_json():
    design, spec = _design("achromat")
    found = compare_with_design(design, design_maps(design, spec), spec)
    data = found.to_json()
    assert data["matches"] is True and data["diagnosis"] == []
    assert data["position_rms_px"] == pytest.approx(0.0, abs=1e-9)


def _flat_maps(dy: float) -> FieldMaps:
    u, v, lam = np.array([0.0, 319.0]), np.array([0.0, 199.0]), np.array([450.0, 670.0])
    x = np.array([[10.0, 80.0], [300.0, 370.0]])
    ones = np.ones_like(x)
    return FieldMaps(u, v, lam, x, 20.0 + dy + 0 * x, ones, ones, 0 * ones)


def test_a_difference_no_candidate_explains_is_said_so():
    def shift(amount):
        return {"image": {"decenter_mm": [0.0, amount]}}

    weak = Diagnosis(Candidate("camera shifted in y", "mm", 0.02, shift, 1e3, "um"), 0.01, 0.4)
    found = DesignComparison(_flat_maps(0.0), _flat_maps(3.0), (weak,))
    assert not found.matches and found.best is None and found.named == ()
    assert "no single misalignment explains" in found.verdict
    assert "camera shifted in y by +10 um (explains 40 %)" in found.verdict
    strong = Diagnosis(weak.candidate, 0.01, 0.95)
    named = DesignComparison(_flat_maps(0.0), _flat_maps(3.0), (strong,))
    assert named.best is strong
    assert named.verdict.endswith("camera shifted in y by +10 um (explains 95 %).")
