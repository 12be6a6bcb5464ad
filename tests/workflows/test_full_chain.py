"""The whole chain, ``sassi-bench calibrate``, once on the sim rig: every check passes,
the bundle verifies and carries every stage, and its report names it."""

from __future__ import annotations

import json
import shlex

import numpy as np

from sassi_bench.bundle import load, verify
from sassi_bench.commands import main
from sassi_bench.rig import open_rig
from sassi_bench.rig.sim import truth

STAGES = ("spectral", "response", "guide", "macbeth")


def test_the_full_chain_publishes_a_passing_bundle_with_every_stage(tmp_path, capsys):
    status = main(["calibrate", "--rig", "sim", "--quiet", "--session", "chain",
                   "--data", str(tmp_path)])  # fmt: skip
    out = capsys.readouterr().out
    assert status == 0, out
    assert "all tolerances passed" in out and "FAIL" not in out
    assert "raw frames kept (keep: all): chain-guide-guide" in out  # the shipped keep
    path = tmp_path / "sim" / "v0001"
    verify(path)
    bundle = load(path)
    assert bundle.passed and not bundle.override
    checks = bundle.manifest["quality"]["checks"]
    assert checks and all(c["passed"] for c in checks)
    assert {c["name"].split(".")[0] for c in checks} == set(STAGES)
    assert bundle.response is not None and np.all(np.asarray(bundle.response) > 0)
    # The models against the bench's truth: the homography over the SLM field and the
    # wavelength map at the field centre.
    bench = truth(open_rig("sim"))
    h, w = bundle.slm_shape
    v, u = np.mgrid[0:h:40, 0:w:40].reshape(2, -1).astype(float)
    ones = np.ones_like(u)
    slm = np.stack([u, v, ones])
    guide = np.linalg.solve(bench.guide_to_slm, slm)
    mapped = bundle.guide_to_slm @ (guide / guide[2])
    homography_rms = np.sqrt(np.mean(np.sum((mapped[:2] / mapped[2] - slm[:2]) ** 2, axis=0)))
    assert homography_rms < 0.09  # SLM px; measured 0.048 (the target: 0.3)
    x, y = bundle.slm_to_camera(u, v, 550.0)
    tx, ty = bench.slm_to_camera(u, v, 550.0)
    assert np.sqrt(np.mean((x - tx) ** 2 + (y - ty) ** 2)) < 0.005  # camera px; measured 0.0027
    # The report inside the bundle names the bundle it is published in.
    report = json.loads((path / "report" / "macbeth_report.json").read_text())
    assert report["bundle"]["version"] == "v0001"
    assert [c["name"] for c in report["bundle"]["checks"]] == [c["name"] for c in checks]
    figures = {p.name for p in (path / "report").glob("*.png")}
    assert {"guide_matches.png", "guide_checkerboard.png", "spectral_blur.png"} <= figures
    # It ends with what to run next, and the first of those, a health check of the new
    # bundle as a baseline, runs as printed and finds the bundle holds.
    lines = out[out.index("next:") :].splitlines()
    check = next(line.split() for line in lines if line.split()[1:2] == ["check"])
    assert check[2:6] == ["--rig", "sim", "--bundle", "v0001"]
    assert any(line.split()[1:3] == ["snapshot", "take"] for line in lines if line.strip())
    assert any(line.strip().startswith("open file://") for line in lines)
    assert "spectral_" in out[out.index("the bundle's figures") :]
    assert main(shlex.split(" ".join(check[1:]))) == 0
