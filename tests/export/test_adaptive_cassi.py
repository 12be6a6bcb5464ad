"""adaptive_cassi.mat from a session frame, its mask and guide frames."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.io import loadmat

from sassi_bench.commands import main
from sassi_bench.errors import ProcedureError
from sassi_bench.export.adaptive_cassi import export_adaptive_cassi, guide_to_uint8, lcos_mask


@pytest.fixture(scope="module")
def capture(sim_bundle, snapshot_session, tmp_path_factory):
    bundle, _ = sim_bundle
    out = tmp_path_factory.mktemp("exp1")
    done = export_adaptive_cassi(
        bundle, snapshot_session, 0, out, guide_steps=[2, 3], guide_dark_steps=[4], vsize=7
    )
    return done, loadmat(done.path)


def test_contents(capture, sim_bundle, snapshot_session):
    done, mat = capture
    bundle, _ = sim_bundle
    hl, wl = bundle.slm_shape
    mask = mat["lcos_mask"]
    assert mask.dtype == np.uint8 and mask.shape == (hl, wl)
    expected = np.zeros((hl, wl), np.uint8)
    expected[3::20, 7::100] = 255  # the snapshot's pinholes (tests/export/conftest.py)
    np.testing.assert_array_equal(mask, expected)
    assert set(np.unique(mask)) == {0, 255} and done.open_pixels == int((mask == 255).sum())
    frame = snapshot_session.read_frame(0)
    assert mat["cassi_img"].dtype == frame.dtype
    np.testing.assert_array_equal(mat["cassi_img"], frame)
    assert mat["limits"].dtype == np.int32
    np.testing.assert_array_equal(mat["limits"].ravel(), [0, hl, 0, wl])
    # The window given; int32 (1, 1), which int(data['vsize'].item()) makes a Python int.
    assert mat["vsize"].dtype == np.int32 and mat["vsize"].shape == (1, 1)
    assert int(mat["vsize"].item()) == done.vsize == 7 and done.vsize_choice is None
    assert not done.notes  # the session and the bundle share the rig description
    guide = mat["guide_img_rec"]
    assert guide.dtype == np.uint8 and guide.shape == (hl, wl, 3)
    # The dark-subtracted mean of the two guide frames, on the SLM grid, scaled linearly.
    mean = (snapshot_session.read_frame(2).astype(float) + snapshot_session.read_frame(3)) / 2
    warped = bundle.warp_guide_to_slm((mean - snapshot_session.read_frame(4)).astype(np.float32))
    white = float(mat["guide_white_level"].ravel()[0])
    inside = (warped < white).all(axis=2)
    np.testing.assert_allclose(guide[inside], 255 * warped[inside] / white, atol=0.5 + 1e-6)
    # The chart is colourful: the channels differ (RGB, not grey).
    assert np.abs(guide[..., 0].astype(int) - guide[..., 2]).mean() > 5
    assert str(mat["session_id"][0]) == "snapshot" and int(mat["spectral_step"].ravel()[0]) == 0


def test_limits_crop_the_guide(sim_bundle, snapshot_session, capture, tmp_path):
    bundle, _ = sim_bundle
    done = export_adaptive_cassi(
        bundle, snapshot_session, 0, tmp_path, guide_steps=[2, 3], guide_dark_steps=[4],
        limits=(50, 350, 100, 600), vsize=7,
    )  # fmt: skip
    mat = loadmat(done.path)
    np.testing.assert_array_equal(mat["limits"].ravel(), [50, 350, 100, 600])
    assert mat["guide_img_rec"].shape == (300, 500, 3)
    assert mat["lcos_mask"].shape == bundle.slm_shape  # the mask stays whole
    with pytest.raises(ProcedureError, match="not a crop"):
        export_adaptive_cassi(
            bundle, snapshot_session, 0, tmp_path / "x", guide_steps=[2], limits=(0, 500, 0, 10),
            vsize=7,
        )  # fmt: skip


def test_refusals(sim_bundle, snapshot_session, capture, tmp_path):
    bundle, _ = sim_bundle
    done, _ = capture
    with pytest.raises(ProcedureError, match="grey levels"):
        lcos_mask({"kind": "uniform", "level": 128}, (4, 4))
    with pytest.raises(ProcedureError, match="no captured spectral frame"):
        export_adaptive_cassi(bundle, snapshot_session, 2, tmp_path, guide_steps=[3])
    with pytest.raises(ProcedureError, match="no captured guide frame"):
        export_adaptive_cassi(bundle, snapshot_session, 0, tmp_path, guide_steps=[1])
    with pytest.raises(ProcedureError, match="already exists"):
        export_adaptive_cassi(
            bundle, snapshot_session, 0, done.path.parent, guide_steps=[2], vsize=7
        )
    with pytest.raises(ProcedureError, match="not a positive odd number of rows"):
        export_adaptive_cassi(bundle, snapshot_session, 0, tmp_path, guide_steps=[2], vsize=4)
    with pytest.raises(ProcedureError, match="dark"):
        guide_to_uint8(np.zeros((4, 4, 3)))


def test_cli_snapshot_export(capsys, sim_bundle, snapshot_session, tmp_path):
    bundle, root = sim_bundle
    base = ["snapshot", "export", "--session", "snapshot", "--data", str(root)]
    out = tmp_path / "exp"
    code = main([
        *base, "--tag", "role=snapshot", "--guide-tag", "role=guide",
        "--guide-dark-tag", "role=guide_dark", "--bundle", str(bundle.path), "--out", str(out),
        "--vsize", "5",
    ])  # fmt: skip
    printed = capsys.readouterr().out
    assert code == 0, printed
    assert "step 0" in printed and "guide steps [2, 3]" in printed and "minus dark [4]" in printed
    assert "vsize 5 (as given)" in printed
    mat = loadmat(out / "adaptive_cassi.mat")
    np.testing.assert_array_equal(mat["guide_steps"].ravel(), [2, 3])
    # Three guide frames in the session: which one to pair must be said.
    assert main([*base, "--step", "0", "--out", str(tmp_path / "b")]) == 2
    assert "ambiguous" in capsys.readouterr().err


def test_a_snapshot_session_exports_its_exact_mask(calibrated_sim, sim_bundle, tmp_path):
    """Snapshot capture stores a mask as a ``pixels`` pattern (guide at step 0, spectral at
    step 1): the export gives that mask back pixel for pixel."""
    from sassi_bench.acquire.patterns import pixels_descriptor
    from sassi_bench.acquire.plan import Plan, Step
    from sassi_bench.acquire.runner import run_plan
    from sassi_bench.acquire.session import Session

    rig = calibrated_sim[0]
    bundle, root = sim_bundle
    mask = np.zeros(bundle.slm_shape, bool)
    mask[np.random.default_rng(3).integers(0, mask.shape[0], 40), 17::97] = True
    pattern = pixels_descriptor(mask)
    plan = Plan(
        "snapshot",
        (
            Step("guide", "halogen", 0.002, pattern, {"role": "guide"}),
            Step("spectral", "halogen", 0.01, pattern, {"role": "snapshot"}),
        ),
        {"scene": "colorchecker"},
    )
    session = run_plan(
        rig, plan, Session.create(rig.description, plan, session_id="adaptive-f000", data=root)
    )
    done = export_adaptive_cassi(bundle, session, 1, tmp_path, guide_steps=[0], vsize=9)
    mat = loadmat(done.path)
    np.testing.assert_array_equal(mat["lcos_mask"], np.where(mask, 255, 0).astype(np.uint8))
    np.testing.assert_array_equal(mat["cassi_img"], session.read_frame(1))
    assert done.open_pixels == int(mask.sum())
