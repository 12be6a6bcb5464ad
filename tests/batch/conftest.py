"""Small pinhole scans of the sim rig and a two-worker local cluster, shared by the batch
tests."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load
from sassi_bench.rig.sim import truth

_spec = importlib.util.spec_from_file_location(
    "batch_synthetic_bundle", Path(__file__).parents[1] / "bundle" / "conftest.py"
)
synthetic_models = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = synthetic_models
_spec.loader.exec_module(synthetic_models)

#: Every how many pinhole offsets a test scan keeps (25: 20 of the 500 frames).
EVERY = 25


def thin_scan(rig, scene: str, session_id: str, data, every: int = EVERY) -> Session:
    """A pinhole scan of ``scene`` with every ``every``-th offset, captured under ``data``."""
    full = scan_plan(rig.slm.shape, "led", 0.1, scene=scene)
    keep = [s for i, s in enumerate(full.steps) if s.tags["role"] == "closed" or i % every == 1]
    plan = Plan(full.name, tuple(keep), full.parameters)
    session = Session.create(rig.description, plan, session_id=session_id, data=data)
    run_plan(rig, plan, session, progress=False)
    return session


@pytest.fixture(scope="session")
def scans(sim_rig, tmp_path_factory):
    """(data root, bundle, session ids): the synthetic bundle of the bundle tests (the batch
    machinery is under test, not the calibration) and three thin scans of the sim rig
    (chart, diffuser, PCB). Tests that break sessions do it in a copy."""
    data = tmp_path_factory.mktemp("batch") / "data"
    bundle = load(synthetic_models.publish_synthetic(data))
    ids = [
        thin_scan(sim_rig, scene, f"scan-{scene}", data).id
        for scene in ("colorchecker", "white", "pcb")
    ]
    return data, bundle, ids


@pytest.fixture(scope="session")
def client():
    """Two single-threaded worker processes (so that killing one is real), shared by every
    batch test: the command-line tests reach it with ``--scheduler``."""
    from sassi_bench.batch.engine import batch_client

    with batch_client(workers=2) as opened:
        yield opened


@pytest.fixture(scope="module")
def chart(calibrated_sim, tmp_path_factory):
    """(data root, bundle): the suite's calibrated sim bundle and a chart scan of every 10th
    pinhole offset (a score needs the real wavelength map and enough pixels per patch)."""
    rig, result, _ = calibrated_sim
    data = tmp_path_factory.mktemp("batch-validate")
    thin_scan(rig, "colorchecker", "scan-chart", data, every=10)
    return data, load(result.bundle_path)


@pytest.fixture(scope="module")
def corners(sim_rig):
    """The true SLM (u, v) centres of patches 1, 6, 24 and 19 (scene labels 2, 7, 25, 20):
    thin test scans leave too few pixels for the detector."""
    scene = truth(sim_rig).bench.scene_named("colorchecker")
    centres = []
    for label in (2, 7, 25, 20):
        rows, cols = np.nonzero(scene.labels == label)
        centres.append((cols.mean() - scene.margin, rows.mean() - scene.margin))
    return centres
