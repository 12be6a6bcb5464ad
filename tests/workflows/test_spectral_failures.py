"""The spectral calibration refuses or flags bad input instead of publishing nonsense."""

import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.plan_geometry import planned_spectral
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import sweep_plan
from sassi_bench.calibrate.dispersion import fit_dispersion
from sassi_bench.errors import ConfigError
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.sweeps import analyse_sweep
from sassi_bench.workflows.spectral import run_spectral_calibration


def test_a_laser_mislabelled_by_10_nm_fails_the_leave_one_out_check(sim_rig, true_laser_maps):
    lasers = [450.0, 520.0, 532.0, 635.0, 670.0]
    good = fit_dispersion(true_laser_maps(sim_rig, lasers), "N-BK7", sim_rig.slm.shape)
    assert good.leave_one_out_rms_nm < 0.0032  # measured 0.0016 nm
    labels = [450.0, 520.0, 542.0, 635.0, 670.0]  # the 532 nm line labelled 542 nm
    bad = fit_dispersion(true_laser_maps(sim_rig, labels, lasers), "N-BK7", sim_rig.slm.shape)
    tolerance = load_procedure("spectral_calibration")["tolerances"]["leave_one_out_rms_nm"]
    assert bad.leave_one_out_rms_nm > 5 * tolerance


def test_a_missing_laser_is_a_clear_error_before_any_capture(tmp_path):
    rig = open_rig("sim")
    proc = load_procedure("spectral_calibration")
    proc["lasers_nm"] = [405, 450, 520, 532, 635, 670]
    with pytest.raises(
        ConfigError, match=r"laser line\(s\) \[405.0\] nm that rig 'sim' does not have"
    ):
        run_spectral_calibration(rig, proc, data=tmp_path, progress=False)
    assert not (tmp_path / "sessions").exists()


def test_too_few_lasers_cannot_fix_the_dispersion(sim_rig, true_laser_maps):
    maps = true_laser_maps(sim_rig, [450.0, 635.0])
    with pytest.raises(ValueError, match="cannot fix a degree-2 dispersion model"):
        fit_dispersion(maps, "N-BK7", sim_rig.slm.shape)


def test_saturated_laser_frames_are_refused_with_a_clear_error(tmp_path):
    rig = open_rig("sim")
    proc = planned_spectral(load_procedure("spectral_calibration"), rig.description)
    proc["blur"] = {**proc["blur"], "frames": 1}
    plan = sweep_plan(proc, rig.slm.shape, {532.0: 2.0}, list(range(0, 256, 16)))
    session = Session.create(rig.description, plan, session_id="saturated", data=tmp_path)
    run_plan(rig, plan, session, progress=False)
    with pytest.raises(
        ValueError, match=r"sweep decoding at 532 nm: only \d+ camera pixels decoded"
    ):
        analyse_sweep(session, proc, rig.slm.shape, saturation=65535)


def test_procedure_rejects_unknown_keys(tmp_path):
    import yaml

    proc = load_procedure("spectral_calibration")
    proc.pop("source")
    proc["sweep"]["moed"] = "lines"
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(proc))
    with pytest.raises(ConfigError, match=r"sweep\.moed: unknown key .*did you mean 'mode'"):
        load_procedure("spectral_calibration", path)


def test_resuming_with_another_procedure_is_refused(tmp_path):
    rig = open_rig("sim")
    proc = planned_spectral(load_procedure("spectral_calibration"), rig.description)
    plan = sweep_plan(proc, rig.slm.shape, {450.0: 0.01}, None, {})
    plan = type(plan)(plan.name, plan.steps[:2], {"procedure": {"lasers_nm": [450]}})
    Session.create(rig.description, plan, session_id="old-sweep", data=tmp_path)
    with pytest.raises(ConfigError, match="different lasers"):
        run_spectral_calibration(rig, proc, session_id="old", data=tmp_path, progress=False)


def test_fit_settings_may_change_between_capture_and_analysis():
    from types import MappingProxyType, SimpleNamespace

    from sassi_bench.workflows.spectral import _check_same_procedure

    proc = load_procedure("spectral_calibration")
    stored = MappingProxyType({k: v for k, v in proc.items() if k != "source"})
    session = SimpleNamespace(id="s", plan=SimpleNamespace(parameters={"procedure": stored}))
    edited = {**proc, "fit": {**proc["fit"], "exclude_regions_slm_px": [[0, 0, 10, 10]]}}
    lasers = (450, 520, 532, 635, 670)
    _check_same_procedure(session, edited, lasers)  # analysis-only change: resumes
    # Leaving the lasers to the rig is the same capture as pinning the rig's lasers.
    _check_same_procedure(session, {**proc, "lasers_nm": list(lasers)}, lasers)
    with pytest.raises(ConfigError, match="different lasers"):
        _check_same_procedure(session, {**proc, "lasers_nm": [450, 532, 670]}, lasers)
    with pytest.raises(ConfigError, match="different lasers"):
        changed = {**proc, "exposure": {**proc["exposure"], "max_s": 1.0}}
        _check_same_procedure(session, changed, lasers)


@pytest.mark.parametrize("rig_name", ["tests/rigs/prism-sf10.yaml", "tests/rigs/prism-nbk7.yaml"])
def test_leave_one_out_grades_the_interior_lasers_and_catches_a_mislabelled_one(
    rig_name, true_laser_maps
):
    """Four lasers: the end lasers' refits extrapolate and are recorded, not graded; the
    interior lines' refits grade the map, and a line 1 or 2 nm off its label fails them."""
    rig = open_rig(rig_name)
    lasers = [405.0, 488.0, 561.0, 640.0]
    glass, shape = rig.description.prism.glass, rig.slm.shape
    tolerance = load_procedure("spectral_calibration")["tolerances"]["leave_one_out_rms_nm"]
    right = fit_dispersion(true_laser_maps(rig, lasers), glass, shape)
    assert right.interior_lines == [488.0, 561.0]
    # Measured: interior 0.012 / 0.002 nm RMS; the end lasers' refits 0.44 / 0.11 px off.
    assert right.leave_one_out_rms_nm < 0.05 and right.leave_one_out_max_px < 0.2
    assert right.extrapolation_max_px > 2 * right.leave_one_out_max_px
    for labels in ([405.0, 488.0, 560.0, 640.0], [405.0, 488.0, 561.0, 642.0]):
        wrong = fit_dispersion(true_laser_maps(rig, labels, lasers), glass, shape)
        # Measured: 0.99-1.00 nm (561 labelled 560), 0.62-0.63 nm (640 labelled 642).
        assert wrong.leave_one_out_rms_nm > tolerance
