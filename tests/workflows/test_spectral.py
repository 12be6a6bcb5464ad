"""The spectral calibration run again on its own sessions: the operator is not asked."""

from __future__ import annotations

import dataclasses
import shutil

import numpy as np

from sassi_bench import open_rig
from sassi_bench.procedure import load_procedure
from sassi_bench.workflows.spectral import run_spectral_calibration


class _AskedLight:
    """A light that records every switch a procedure asks for."""

    def __init__(self, light, asked):
        self._light, self._asked = light, asked

    def __getattr__(self, name):
        return getattr(self._light, name)

    def select(self, name):
        self._asked.append(("light", name))
        self._light.select(name)


def test_a_finished_calibration_run_again_asks_for_no_target_and_no_light(calibrated_sim, tmp_path):
    """On a real bench each request is the operator placing a target or switching a
    laser; a run resumed after its captures finished (the analysis interrupted, say)
    asks for none and gives the same models."""
    _, first, data = calibrated_sim
    shutil.copytree(data / "sessions", tmp_path / "sessions")
    asked: list = []
    rig = open_rig("sim")
    rig = dataclasses.replace(
        rig,
        scene=None,  # as a hardware rig opens: nothing known in front
        scene_setter=lambda *args: asked.append(("scene", *args)),
        light=_AskedLight(rig.light, asked),
    )
    again = run_spectral_calibration(
        rig, load_procedure("spectral_calibration"), data=tmp_path, progress=False,
        session_id="acc",
    )  # fmt: skip
    assert asked == []
    np.testing.assert_array_equal(again.dispersion.bins.edges_nm, first.dispersion.bins.edges_nm)
