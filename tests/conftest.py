"""Shared fixtures: simulated rigs are opened once per test session."""

from __future__ import annotations

import shutil

import pytest

from sassi_bench import open_rig
from sassi_bench.rig.config import load_rig_description, rig_description_from_dict


@pytest.fixture(scope="session", autouse=True)
def _design_cache(tmp_path_factory):
    """Traced optical designs go to one folder per test session (traced once in it),
    unless ``SASSI_BENCH_DESIGN_CACHE`` names a folder to keep them across runs."""
    import os

    if os.environ.get("SASSI_BENCH_DESIGN_CACHE"):
        yield
        return
    os.environ["SASSI_BENCH_DESIGN_CACHE"] = str(tmp_path_factory.mktemp("design-cache"))
    yield
    os.environ.pop("SASSI_BENCH_DESIGN_CACHE", None)


@pytest.fixture(scope="session")
def design_rigs():
    """The shipped design rigs, opened once per test session (skipped without optiland).

    ``design_rigs(name)`` for ``"achromat"`` or ``"singlet"``.
    """
    pytest.importorskip(
        "optiland",
        reason='design rigs need the optiland ray tracer: pip install "sassi-bench[design]"',
    )
    opened = {}

    def _open(name: str):
        if name not in opened:
            opened[name] = open_rig(f"sim-{name}")
        return opened[name]

    return _open


@pytest.fixture(scope="session")
def sim_rig():
    """The default virtual bench (tests set the scene, light and pattern they need)."""
    return open_rig("sim")


@pytest.fixture()
def sim_dict():
    """The default rig description as a mutable dict, for building odd rigs."""
    return load_rig_description("sim").to_dict()


@pytest.fixture()
def make_rig():
    """Open a rig from a (modified) description dict."""

    def _make(data: dict):
        return open_rig(rig_description_from_dict(data))

    return _make


@pytest.fixture(scope="module")
def module_folder(request, tmp_path_factory):
    """Make folders that go when their module's tests are done, unless one failed.

    pytest keeps a module fixture's folder to the end of the run; the suite's frames
    (captures, cubes, notebooks' runs) then peak at several GB under it.
    """
    made = []

    def make(name: str):
        made.append(tmp_path_factory.mktemp(name))
        return made[-1]

    yield make
    if request.session.testsfailed == 0:
        for folder in made:
            shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="session")
def calibrated_sim(tmp_path_factory):
    """The default virtual bench, spectrally calibrated once per test session.

    Returns (rig, result, data_root); the bundle is published under data_root.
    """
    from sassi_bench.procedure import load_procedure
    from sassi_bench.workflows.spectral import run_spectral_calibration

    rig = open_rig("sim")
    data = tmp_path_factory.mktemp("calibrated-sim")
    result = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=data, progress=False, session_id="acc"
    )
    return rig, result, data


@pytest.fixture(scope="session")
def true_laser_maps():
    """Per-laser SLM -> camera maps fitted to a virtual bench's true ray trace.

    ``maps(rig, labels, wavelengths=None)``: one LaserMap per label, rendered at
    ``wavelengths`` (default: each labelled line's true centre on that bench).
    """
    import numpy as np

    from sassi_bench.calibrate.dispersion import LaserMap
    from sassi_bench.calibrate.field import fit_field
    from sassi_bench.rig.sim import truth

    def _maps(rig, labels, wavelengths=None):
        t = truth(rig)
        h, w = rig.slm.shape
        v, u = np.mgrid[0:h:10, 0:w:10].astype(float)
        if wavelengths is None:
            wavelengths = [t.laser_centre_nm(label) for label in labels]
        maps = []
        for wavelength, label in zip(wavelengths, labels, strict=True):
            x, y = t.slm_to_camera(u, v, wavelength)
            fx = fit_field(u.ravel(), v.ravel(), x.ravel(), (h, w), 5)
            fy = fit_field(u.ravel(), v.ravel(), y.ravel(), (h, w), 5)
            maps.append(LaserMap(label, fx, fy, x.size))
        return maps

    return _maps


@pytest.fixture(scope="session")
def guided_bundle(calibrated_sim, tmp_path_factory):
    """The session's calibrated sim bundle plus the bench's true guide homography (the
    guide registration has its own tests), in a data root of its own."""
    import dataclasses

    from sassi_bench.bundle import load, publish
    from sassi_bench.rig.sim import truth

    rig, _, data = calibrated_sim
    spectral = load(rig="sim", data=data)
    root = tmp_path_factory.mktemp("snapshot-data")
    models = dataclasses.replace(
        spectral.models, guide_to_slm=truth(rig).guide_to_slm, guide_info={"source": "truth"}
    )
    path = publish(
        models, rig=rig.description, quality={"checks": [], "residuals": {}},
        procedure=dict(spectral.manifest["procedure"]), data=root,
    )  # fmt: skip
    return rig, load(path), spectral, root
