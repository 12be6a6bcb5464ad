"""``align``: the readings of a misaligned virtual bench against its truth, an aligned one
reading aligned, and Ctrl-C freeing the rig."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import sassi_bench.rig
from sassi_bench.acquire.patterns import open_pixels
from sassi_bench.reduce.alignment import alignment_pattern
from sassi_bench.rig import open_rig
from sassi_bench.rig.sim import truth
from sassi_bench.workflows.align import run_alignment

MISALIGNED = Path(__file__).parents[1] / "rigs" / "misaligned.yaml"


def readings(rig, tmp_path):
    (done,) = run_alignment(rig, data=tmp_path)
    return {r.name: r for r in done.readings}


@pytest.fixture(scope="module")
def misaligned(tmp_path_factory):
    rig = open_rig(MISALIGNED)
    return rig, readings(rig, tmp_path_factory.mktemp("align"))


def test_the_rolled_prism_reads_true(misaligned):
    rig, found = misaligned
    roll = found["streak roll 450-670 nm"]
    value, target = roll.numbers
    rows, cols = open_pixels(alignment_pattern(rig.description), rig.slm.shape)
    xa, ya = truth(rig).slm_to_camera(cols.astype(float), rows.astype(float), 450.0)
    xb, yb = truth(rig).slm_to_camera(cols.astype(float), rows.astype(float), 670.0)
    true = float(np.median(np.rad2deg(np.arctan2(yb - ya, xb - xa))))
    # Measured 0.0014 deg from the truth here (0.008 deg on the aligned sim rig).
    assert abs(value - true) < 0.02
    assert not roll.ok and "roll the prism 0.48 deg clockwise" in roll.advice
    assert true - target == pytest.approx(0.48, abs=0.01)  # the 0.5 deg roll, as imaged


def test_the_defocused_camera_reads_the_right_way(misaligned):
    _, found = misaligned
    focus = found["best focus"]
    best, designed = focus.numbers
    # as_built.focus_shift_nm: 25: best focus at 545 nm; read 544 nm.
    assert designed == pytest.approx(520, abs=1)
    assert best == pytest.approx(545, abs=3)
    assert not focus.ok and "to the blue" in focus.advice
    assert not found["spot width 450 nm"].ok  # blue spots blurred: wider than designed


def test_the_footprint_is_where_the_truth_puts_it(misaligned):
    rig, found = misaligned
    footprint = found["footprint 532 nm"]
    corners = np.asarray(footprint.numbers[:8]).reshape(4, 2)
    h, w = rig.slm.shape
    x, y = truth(rig).slm_to_camera(
        np.array([-0.5, w - 0.5, w - 0.5, -0.5]), np.array([-0.5, -0.5, h - 0.5, h - 0.5]), 532.0
    )
    # Measured within 0.17 px of the truth at every corner (the issue asks 2 px).
    assert np.hypot(corners[:, 0] - x, corners[:, 1] - y).max() < 0.4
    assert not footprint.ok and footprint.advice.startswith("move the SLM's image")


def test_every_exposure_is_read(misaligned):
    _, found = misaligned
    exposures = [r for name, r in found.items() if name.startswith("exposure")]
    assert len(exposures) == 5 and all(r.ok for r in exposures)


def test_an_aligned_bench_reads_aligned(tmp_path):
    found = readings(open_rig("sim"), tmp_path)
    assert all(r.ok for r in found.values()), [r.line() for r in found.values() if not r.ok]


def test_ctrl_c_frees_the_rig(tmp_path, monkeypatch, capsys):
    from sassi_bench.commands import main
    from sassi_bench.workflows.rig_lock import driving, held_rigs

    real = sassi_bench.rig.open_rig

    class Interrupted:
        def __init__(self, camera):
            self._camera = camera

        def __getattr__(self, name):
            return getattr(self._camera, name)

        def capture(self):
            raise KeyboardInterrupt

    def interrupted(rig="sim", *, simulate=False):
        opened = real(rig, simulate=simulate)
        return dataclasses.replace(opened, spectral_camera=Interrupted(opened.spectral_camera))

    monkeypatch.setattr(sassi_bench.rig, "open_rig", interrupted)
    status = main(["align", "--rig", "sim", "--no-view", "--data", str(tmp_path)])
    assert status == 130 and capsys.readouterr().err.strip() == "interrupted"
    assert held_rigs() == ()
    with driving(real("sim"), tmp_path, "a second procedure"):
        pass  # the lock is free for the next one
