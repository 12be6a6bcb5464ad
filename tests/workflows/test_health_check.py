"""The calibration health check on the calibrated default bench, still and drifted.

The bundle is the session's calibrated ``sim`` (it has an HgAr and a Ne lamp); the
drifted bench is the same rig opened at 15:00 with its relay drifting 0.2 camera px
along the dispersion since the calibration (``nuisance.drift``: the rig hash is the
same, so the bundle is the rig's).
"""

from __future__ import annotations

import pytest
import yaml

from sassi_bench import open_rig
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.calibrate.lamp_streaks import StreakProfiles
from sassi_bench.commands import main
from sassi_bench.errors import ConfigError, ProcedureError
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.health import GUIDE_NOT_TESTED
from sassi_bench.reduce.lamps import check_lamp_signal
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict
from sassi_bench.rig.sim import truth
from sassi_bench.storage.health_history import HealthHistory, history_path
from sassi_bench.workflows.health_check import check_light, run_health_check

DRIFT_PX = 0.2


def _drifted_dict():
    data = load_rig_description("sim").to_dict()
    data["nuisance"] = {"drift": {"start_h": 6.0, "relay_offset_px_per_h": [DRIFT_PX / 6, 0.0]}}
    return data


@pytest.fixture(scope="module")
def bundle(calibrated_sim):
    _, _, data = calibrated_sim
    return load(rig="sim", data=data)


def test_a_still_bench_holds(calibrated_sim, bundle):
    rig, _, data = calibrated_sim
    check = run_health_check(rig, bundle, load_procedure("health_check"), data=data)
    assert check.verdict == "holds", check.summary()
    assert check.frames == 2 and check.pinholes > 50
    # The bundle's own error and the noise: measured 0.0006 px (mean), 0.0012 px (largest),
    # 0.011 nm. Mostly noise, whose spread over other draws is not measured here: held to
    # 4-5x, still 6-10x under the 0.03 px and 0.05 px it was held to before.
    assert abs(check.field.mean_px) < 0.003 and check.field.max_px < 0.005
    assert check.field.wavelength_max_nm < 0.025
    assert check.parts["guide homography"] == GUIDE_NOT_TESTED
    assert check.processing_s > 0  # recorded; benchmarks/bench_health_check.py times it
    assert "verdict: holds" in check.summary()


def test_without_an_exposure_in_the_bundle_the_procedure_s_search_sets_it(
    calibrated_sim, bundle, monkeypatch
):
    from sassi_bench.workflows import health_check

    rig, _, data = calibrated_sim
    light = check_light(rig.description, load_procedure("health_check"))
    recorded = health_check._lamp_exposure(bundle, light)  # the calibration's, at 0.6
    monkeypatch.setattr(health_check, "_lamp_exposure", lambda *_: None)  # an older bundle
    searched = {}

    def search(*args, **kwargs):
        searched.update(kwargs, found=auto_exposure(*args, **kwargs))
        return searched["found"]

    auto_exposure = health_check.auto_exposure
    monkeypatch.setattr(health_check, "auto_exposure", search)
    procedure = load_procedure("health_check")
    # A limit under what the lamp needs (measured: the calibration's 0.056 s) is kept to.
    procedure["exposure"] = {"target_fraction": 0.6, "max_s": 0.03, "start_s": 0.02}
    check = run_health_check(rig, bundle, procedure, data=data)
    assert (searched["target_fraction"], searched["max_s"], searched["start_s"]) == (
        0.6,
        0.03,
        0.02,
    )
    assert recorded > 0.04 and searched["found"] == pytest.approx(0.03)
    assert check.verdict == "holds", check.summary()


def test_the_check_takes_frames_until_its_shift_is_confident_and_resumes(calibrated_sim, bundle):
    rig, _, data = calibrated_sim
    procedure = load_procedure("health_check")
    # sim's map states +-0.0014 px after one frame, 0.0012 after two (measured): a
    # tolerance under both makes the check add frames up to its budget of three.
    procedure["tolerances"]["shift_sigma_px"] = 0.0008
    procedure["max_frames"] = 3
    check = run_health_check(rig, bundle, procedure, data=data, session_id="hc-until")
    record = check.frame_record
    taken = [b.frames for b in record.batches]
    assert taken[0] == 1 and taken[-1] == 3 and taken == sorted(set(taken))
    assert record.outcome == "budget spent" and check.frames == 6  # and 3 closed-SLM frames
    assert record.sigma_px < record.batches[0].sigma_px
    # The still bench measured against its truth (no shift): measured 0.0010 px largest.
    assert check.field.max_px < 0.003
    assert "check frames: 3 pinhole frames (1, then" in check.summary()
    assert record.advice() in check.summary()
    # Run again on the same session: the same decisions on the stored frames, none taken.
    stored = set(Session.open("hc-until", data=data).completed)
    again = run_health_check(rig, bundle, procedure, data=data, session_id="hc-until")
    assert set(Session.open("hc-until", data=data).completed) == stored
    assert again.frame_record.to_json() == record.to_json()


def test_a_drift_of_0_2_px_is_measured_and_flagged(calibrated_sim, bundle):
    _, _, data = calibrated_sim
    rig = open_rig(rig_description_from_dict(_drifted_dict()))
    assert rig.description.sha256() == bundle.manifest["rig_hash"]
    check = run_health_check(rig, bundle, load_procedure("health_check"), data=data)
    assert truth(rig).drift_at(truth(rig).clock_h).offset_px[0] == pytest.approx(DRIFT_PX, abs=1e-3)
    assert check.field.mean_px == pytest.approx(DRIFT_PX, abs=0.002)  # measured 4e-5 off
    assert check.verdict == "recalibrate"
    assert check.parts["dispersion (columns)"] == "recalibrate spectral"
    assert check.parts["dispersion (rows)"] == "holds"


def test_a_bundle_of_another_rig_is_refused_naming_both(bundle):
    other = open_rig("tests/rigs/nuisance-drift.yaml")
    with pytest.raises(ConfigError, match="calibrates rig 'sim', not 'nuisance-drift'"):
        run_health_check(other, bundle, load_procedure("health_check"))
    data = load_rig_description("sim").to_dict()
    data["relay"]["rotation_deg"] = 0.4
    moved = open_rig(rig_description_from_dict(data))
    with pytest.raises(ConfigError, match="another description of rig 'sim'"):
        run_health_check(moved, bundle, load_procedure("health_check"))


def test_a_rig_without_lamps_or_an_unknown_lamp_is_refused():
    data = load_rig_description("sim").to_dict()
    del data["wavelength_lamps"]
    with pytest.raises(ConfigError, match="has no wavelength_lamps"):
        check_light(rig_description_from_dict(data), {"light": "auto"})
    with pytest.raises(ConfigError, match=r"lamp:Kr is not one of the rig's lamps \(lamp:HgAr"):
        check_light(load_rig_description("sim"), {"light": "lamp:Kr"})


def test_lamp_frames_without_light_are_refused_in_one_line(calibrated_sim):
    _, result, _ = calibrated_sim
    (streaks, *_) = result.anchoring.streaks
    lit = streaks.profiles
    check_lamp_signal(lit)
    off = StreakProfiles(
        lit.light, lit.u, lit.v, lit.columns, lit.profile * 0.001, lit.variance, lit.rows
    )
    with pytest.raises(
        ProcedureError, match=r"^lamp frames lamp:HgAr: the pinhole frames show"
    ) as e:
        check_lamp_signal(off)
    assert "Fix: switch the lamp on" in str(e.value) and "\n" not in str(e.value)


def test_the_command_records_every_check_and_writes_the_trend(calibrated_sim, tmp_path, capsys):
    _, _, data = calibrated_sim
    drifted = tmp_path / "sim-at-15h.yaml"
    drifted.write_text(yaml.safe_dump(_drifted_dict()))
    before = len(HealthHistory(history_path(data)).rows(rig="sim"))
    assert main(["check", "--rig", "sim", "--data", str(data)]) == 0
    assert main(["check", "--rig", str(drifted), "--data", str(data)]) == 1
    out = capsys.readouterr().out
    assert "verdict: holds" in out and "verdict: recalibrate" in out
    assert "next: sassi-bench calibrate spectral" in out
    rows = HealthHistory(history_path(data)).rows(rig="sim")
    assert len(rows) == before + 2
    assert [r["verdict"] for r in rows[-2:]] == ["holds", "recalibrate"]
    assert rows[-1]["shift_x_mean_px"] == pytest.approx(DRIFT_PX, abs=0.01)
    trend = tmp_path / "trend.html"
    argv = ["check", "history", "--rig", "sim", "--data", str(data), "--out", str(trend)]
    assert main(argv) == 0
    assert "Calibration health checks of sim" in trend.read_text()
    assert main(["check", "history", "--rig", "sim", "--data", str(tmp_path)]) == 2
    assert "no health check of rig 'sim'" in capsys.readouterr().err


def test_a_hardware_rigs_bundle_is_its_rig_wherever_the_devices_are_plugged_in(tmp_path):
    import importlib.util
    import sys
    from pathlib import Path
    from types import SimpleNamespace

    from sassi_bench.workflows.health_check import _check_same_rig

    name = "doctest_bundle_synthetic"  # the root conftest's name for the same module
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(
            name, Path(__file__).parents[1] / "bundle" / "conftest.py"
        )
        sys.modules[name] = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(sys.modules[name])
    synthetic = sys.modules[name]
    lab = load_rig_description("lab-example")
    bundle = load(synthetic.publish_synthetic(tmp_path, rig=lab))
    # The bundle keeps the ports and .cti files it was calibrated with; sessions and this
    # check leave them out, so the same bench on another port is the same rig.
    moved = lab.to_dict()
    moved["hardware"]["trigger"]["port"] = "/dev/ttyACM7"
    for desc in (lab, rig_description_from_dict(moved)):
        _check_same_rig(SimpleNamespace(description=desc), bundle)
    changed = lab.to_dict()
    changed["relay"]["rotation_deg"] = changed["relay"]["rotation_deg"] + 0.1
    with pytest.raises(ConfigError, match="another description of rig"):
        _check_same_rig(SimpleNamespace(description=rig_description_from_dict(changed)), bundle)
