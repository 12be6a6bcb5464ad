"""One real pinhole scan of the ColorChecker (default pitch and noise) per test session."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.scan_plans import scan_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import load, publish
from sassi_bench.procedure import load_procedure
from sassi_bench.reduce.scan import assemble_scan
from sassi_bench.workflows.scan import run_scan


@pytest.fixture(scope="session")
def chart_scan(calibrated_sim):
    """(rig, bundle, data root, ScanRun) of the chart under the LED, full Nyquist scan."""
    rig, _, data = calibrated_sim
    bundle = load(rig="sim", data=data)
    run = run_scan(
        rig, bundle, scene="colorchecker", light="led", session_id="macbeth-chart", data=data,
        progress=False,
    )  # fmt: skip
    return rig, bundle, data, run


@pytest.fixture(scope="session")
def thin_white_scan(chart_scan):
    """A diffuser scan under the LED, every 10th pinhole offset (enough pixels per patch)."""
    rig, bundle, data, run = chart_scan
    exposure = run.session.plan.steps[0].exposure_s
    full = scan_plan(rig.slm.shape, "led", exposure, scene="white")
    keep = [s for i, s in enumerate(full.steps) if s.tags["role"] == "closed" or i % 10 == 1]
    plan = Plan(full.name, tuple(keep), full.parameters)
    session = Session.create(rig.description, plan, session_id="macbeth-white-thin", data=data)
    run_plan(rig, plan, session, progress=False)
    return assemble_scan(session, bundle, progress=False)


@pytest.fixture(scope="session")
def procedure():
    return load_procedure("macbeth_validation")


@pytest.fixture(scope="session")
def patch_procedure(procedure):
    """The shipped procedure with the chart's white patch as the white reference."""
    return {**procedure, "white_reference": {**procedure["white_reference"], "source": "patch"}}


def publish_shifted(bundle, rig_description, root, px: float = 1.0, **changes):
    """``bundle`` with its wavelength map moved ``px`` camera px along the streaks (and any
    other model ``changes``), published as its own version under data root ``root``."""
    old = bundle.models
    x = np.array(old.dispersion.x_coeffs)
    x[0, 0] += px  # the constant field term of x: every streak px to the right
    models = dataclasses.replace(
        old, dispersion=dataclasses.replace(old.dispersion, x_coeffs=x), **changes
    )
    path = publish(
        models,
        rig=rig_description,
        quality={"checks": [], "residuals": {}},
        procedure={**dict(bundle.manifest["procedure"]), "test": f"x shifted by {px:g} px"},
        data=root,
    )
    return load(path)


@pytest.fixture(scope="session")
def shifted_bundle(chart_scan, tmp_path_factory):
    """The calibrated bundle with its wavelength map moved 1 camera px along the streaks,
    published as its own version in a separate data root."""
    rig, bundle, _, _ = chart_scan
    return publish_shifted(bundle, rig.description, tmp_path_factory.mktemp("shifted-bundle"))


@pytest.fixture(scope="session")
def shift_wavelength_map():
    """:func:`publish_shifted`, for tests that shift a bundle of their own."""
    return publish_shifted
