"""A calibrated virtual bench, a snapshot session on it and the sassi-mat export of its
bundle, built once per test session."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationModels, load, publish
from sassi_bench.export.sassi_mat import export_sassi_mat
from sassi_bench.rig.sim import truth

#: The snapshot's mask: pinholes 100 px apart in a row (streaks never touch) and 20 rows
#: apart, so that streak-free pixels remain between rows even around the widest blur
#: windows the authors' offset estimate draws around each streak.
SNAPSHOT_PATTERN = {"kind": "pinholes", "pitch": [100, 20], "offset": [7, 3]}
#: Halogen: power in every bin from 400 to 700 nm (the white LED has none below 420 nm).
SNAPSHOT_LIGHT = "halogen"


@pytest.fixture(scope="session")
def sim_bundle(calibrated_sim, tmp_path_factory):
    """The spectrally calibrated sim bundle with the rig's true guide homography added
    (the spectral calibration alone does not register the guide camera)."""
    rig, result, _ = calibrated_sim
    old = load(result.bundle_path).models
    models = CalibrationModels(
        dispersion=old.dispersion,
        bins=old.bins,
        blur=old.blur,
        guide_to_slm=truth(rig).guide_to_slm,
        guide_info={"rms_px": 0.0, "note": "true homography (test fixture)"},
        offset=old.offset,
        response=old.response,
    )
    root = tmp_path_factory.mktemp("export-bundle")
    path = publish(
        models,
        rig=rig.description,
        quality={"checks": [], "residuals": {}},
        procedure={"test": "spectral calibration plus the true guide homography"},
        data=root,
    )
    return load(path), root


@pytest.fixture(scope="session")
def snapshot_session(calibrated_sim, sim_bundle):
    """A session on the ColorChecker under halogen light: a pinhole snapshot (step 0), the
    same exposure with the SLM closed (step 1: the true background under the snapshot),
    two guide frames (steps 2, 3) and a dark guide frame (step 4)."""
    rig = calibrated_sim[0]
    _, root = sim_bundle
    rig.set_scene("colorchecker")
    light, blank = SNAPSHOT_LIGHT, {"kind": "blank"}
    spectral_s = auto_exposure(rig, light, SNAPSHOT_PATTERN)
    guide_s = auto_exposure(rig, light, blank, camera="guide")
    plan = Plan(
        "snapshot",
        (
            Step("spectral", light, spectral_s, SNAPSHOT_PATTERN, {"role": "snapshot"}),
            Step("spectral", light, spectral_s, blank, {"role": "background"}),
            Step("guide", light, guide_s, blank, {"role": "guide"}),
            Step("guide", light, guide_s, blank, {"role": "guide"}),
            Step("guide", "off", guide_s, blank, {"role": "guide_dark"}),
        ),
        {"scene": "colorchecker"},
    )
    session = Session.create(rig.description, plan, session_id="snapshot", data=root)
    return run_plan(rig, plan, session, progress=False)


@pytest.fixture(scope="session")
def exported(sim_bundle, tmp_path_factory):
    """``export_sassi_mat`` of the sim bundle at all its bins."""
    bundle, _ = sim_bundle
    return export_sassi_mat(bundle, tmp_path_factory.mktemp("sassi-mat"), progress=False)


@pytest.fixture(scope="session")
def loaded(exported):
    """The two exported files read back with scipy."""
    from scipy.io import loadmat

    return (
        loadmat(exported.folder / "calibstack.mat"),
        loadmat(exported.folder / "reverse_lookup.mat"),
    )


@pytest.fixture()
def rng():
    return np.random.default_rng(20261124)


@pytest.fixture(scope="session")
def synthetic():
    """The synthetic bundle helpers of ``tests/bundle/conftest.py`` (a 640 x 400 SLM on a
    2048 x 2048 camera, 2.8 camera px per SLM px)."""
    path = Path(__file__).parents[1] / "bundle" / "conftest.py"
    spec = importlib.util.spec_from_file_location("synthetic_bundle_helpers", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # the helpers look themselves up there
    spec.loader.exec_module(module)
    return module


#: ``tests/export/vendored_sassi`` holds the SASSI authors' files, not tests.
collect_ignore = ["vendored_sassi"]


@pytest.fixture(scope="session")
def sassi_root(calibrated_sim, sim_bundle, exported, tmp_path_factory):
    """A lab's folder for the authors' code: the bundle export in ``calibration/`` and an
    adaptive snapshot of the natural scene (the snapshot procedure's mask and light)
    exported with its chosen window in ``exp1/``. Returns (root, export result, video)."""
    import os

    from sassi_bench.acquire.snapshots import GUIDE_STEP, SPECTRAL_STEP
    from sassi_bench.export.adaptive_cassi import export_adaptive_cassi
    from sassi_bench.procedure import load_procedure
    from sassi_bench.workflows.snapshot import take_snapshots

    rig = calibrated_sim[0]
    bundle, data = sim_bundle
    video = take_snapshots(
        rig, bundle, load_procedure("snapshot_validation"), scene="natural",
        session_id="natural", data=data, progress=False,
    )  # fmt: skip
    root = tmp_path_factory.mktemp("sassi-root")
    os.symlink(exported.folder, root / "calibration")
    done = export_adaptive_cassi(
        bundle, video.frames[0], SPECTRAL_STEP, root / "exp1", guide_steps=[GUIDE_STEP]
    )
    return root, done, video
