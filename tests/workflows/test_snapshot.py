"""`sassi-bench snapshot take`, `snapshot reconstruct` and `snapshot export` on the sim
rig, with the snapshot ids `take` prints (the video's, or one frame's)."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
from scipy.io import loadmat

from sassi_bench.acquire.session import Session
from sassi_bench.acquire.snapshot_ids import open_snapshots, resolve_snapshot
from sassi_bench.acquire.snapshots import CLOSED_STEP, GUIDE_STEP, SPECTRAL_STEP
from sassi_bench.commands import main


@pytest.fixture(scope="module")
def taken(guided_bundle, module_folder):
    """Two frames of the natural scene moving, taken and written once."""
    _, bundle, _, root = guided_bundle
    out = module_folder("snapshots")
    status = main(
        ["snapshot", "take", "--rig", "sim", "--bundle", str(bundle.path), "--frames", "2",
         "--moving", "--session", "mov", "--data", str(root), "--out", str(out), "--quiet"]
    )  # fmt: skip
    return status, bundle, root, out


def test_take_writes_both_cubes_envi_and_a_quick_look_per_frame(taken):
    status, bundle, _, out = taken
    assert status == 0
    for t in range(2):
        name = f"mov-f{t:03d}"
        for method in ("rank1", "guided"):
            with xr.open_dataset(out / f"{name}-{method}.nc") as ds:
                cube = ds["radiance"]
                assert cube.dims == ("y", "x", "wavelength")
                assert cube.shape == (*bundle.slm_shape, bundle.wavelengths.size)
                np.testing.assert_allclose(ds["wavelength"].values, bundle.wavelengths)
                assert ds.attrs["bundle_version"] == bundle.version
                assert ds.attrs["session"] == name
                # What the cube was divided by travels with it (this spectral-only bundle
                # has no response: the cube stays in camera ADU per second).
                assert float(ds["exposure_time"]) > 0
                if bundle.response is None:
                    assert "response" not in ds
                    assert ds["radiance"].attrs["units"] == "count s-1"
                else:
                    np.testing.assert_array_equal(ds["response"].values, bundle.response)
                    assert ds["radiance"].attrs["units"] == "1"
                values = cube.values
                assert np.isfinite(values).all() and float(values.max()) > 0
            assert (out / f"{name}-{method}.hdr").is_file()
        assert (out / f"{name}.png").stat().st_size > 10_000


def test_each_mask_comes_from_the_previous_guide_frame(taken):
    _, _, root, _ = taken
    video = open_snapshots("mov", data=root)
    assert len(video.frames) == 2
    assert video.pose(1).shift_px == pytest.approx((2.0, 1.0))
    # The scene moved between the frames, so their adaptive masks differ.
    assert not np.array_equal(video.mask(0), video.mask(1))
    assert all(f.plan.parameters["mask_kind"] == "adaptive" for f in video.frames)


def test_a_moving_scene_takes_no_closed_frame_and_a_still_one_does(taken, tmp_path):
    """The closed SLM's leak is measured only where the scene holds still between the
    snapshot and the closed frame; it is taken at the snapshot's exposure."""
    _, bundle, root, _ = taken
    moving = open_snapshots("mov", data=root)
    assert [moving.closed(t) for t in range(2)] == [None, None]
    status = main(
        ["snapshot", "take", "--rig", "sim", "--bundle", str(bundle.path), "--frames", "1",
         "--session", "still", "--data", str(root), "--out", str(tmp_path), "--quiet"]
    )  # fmt: skip
    assert status == 0
    still = open_snapshots("still", data=root)
    steps = still.frames[0].plan.steps
    assert steps[CLOSED_STEP].pattern == {"kind": "blank"}
    assert steps[CLOSED_STEP].exposure_s == steps[SPECTRAL_STEP].exposure_s
    closed, spectral = still.closed(0), still.spectral(0)
    assert closed.shape == spectral.shape
    # The open pixels' streaks add light: the snapshot frame is brighter than the leak.
    assert float(spectral.astype(float).sum()) > float(closed.astype(float).sum())


def test_reconstruct_from_disk_gives_the_cubes_take_wrote(taken, tmp_path):
    _, bundle, root, out = taken
    status = main(
        ["snapshot", "reconstruct", "--session", "mov", "--bundle", str(bundle.path),
         "--data", str(root), "--out", str(tmp_path), "--no-envi", "--quiet"]
    )  # fmt: skip
    assert status == 0 and not list(tmp_path.glob("*.hdr"))
    for name in ("mov-f000-rank1.nc", "mov-f001-guided.nc"):
        with xr.open_dataset(out / name) as a, xr.open_dataset(tmp_path / name) as b:
            np.testing.assert_array_equal(a["radiance"].values, b["radiance"].values)


def test_take_again_resumes_the_sessions_and_never_overwrites_cubes(taken, capsys):
    _, bundle, root, out = taken
    before = {p.name: p.stat().st_mtime_ns for p in out.iterdir()}
    frames_before = Session.open("mov-f001", data=root).completed
    status = main(
        ["snapshot", "take", "--rig", "sim", "--bundle", str(bundle.path), "--frames", "2",
         "--moving", "--session", "mov", "--data", str(root), "--out", str(out), "--quiet"]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and "already exist" in err and "Fix: " in err
    assert {p.name: p.stat().st_mtime_ns for p in out.iterdir()} == before
    assert Session.open("mov-f001", data=root).completed == frames_before


def test_reconstruct_an_unknown_snapshot_names_it(tmp_path, capsys):
    status = main(
        ["snapshot", "reconstruct", "--session", "nothing-here", "--data", str(tmp_path),
         "--out", str(tmp_path / "o")]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and "no snapshot 'nothing-here'" in err and "snapshots there: none" in err


def test_one_frame_id_reconstructs_that_frame_only(taken, tmp_path, capsys):
    _, bundle, root, out = taken
    status = main(
        ["snapshot", "reconstruct", "--session", "mov-f001", "--bundle", str(bundle.path),
         "--data", str(root), "--out", str(tmp_path), "--no-envi", "--quiet"]
    )  # fmt: skip
    assert status == 0 and "1 of 2 frames" in capsys.readouterr().out
    assert sorted(p.name for p in tmp_path.glob("*.nc")) == [
        "mov-f001-guided.nc",
        "mov-f001-rank1.nc",
    ]
    with (
        xr.open_dataset(out / "mov-f001-rank1.nc") as a,
        xr.open_dataset(tmp_path / "mov-f001-rank1.nc") as b,
    ):
        np.testing.assert_array_equal(a["radiance"].values, b["radiance"].values)


def test_export_takes_the_id_as_printed_and_finds_the_frames_itself(taken, tmp_path, capsys):
    """No --step or --guide-step: the spectral step is the one tagged role=snapshot and the
    guide the frame's guide step. The video's id exports one folder per frame (cassi.py
    reads one capture per folder); a frame's id exports that frame into --out."""
    _, bundle, root, _ = taken
    common = ["--bundle", str(bundle.path), "--data", str(root), "--vsize", "9"]
    assert main(["snapshot", "export", "--session", "mov", "--out", str(tmp_path / "all"),
                 *common]) == 0  # fmt: skip
    printed = capsys.readouterr().out
    video = open_snapshots("mov", data=root)
    for t in range(2):
        mat = loadmat(tmp_path / "all" / f"mov-f{t:03d}" / "adaptive_cassi.mat")
        assert str(mat["session_id"][0]) == f"mov-f{t:03d}"
        assert mat["spectral_step"].item() == SPECTRAL_STEP
        assert mat["guide_steps"].ravel().tolist() == [GUIDE_STEP]
        np.testing.assert_array_equal(mat["lcos_mask"] > 0, video.mask(t))
    assert "(mov-f000, mov-f001)" in printed and "expname set to each name" in printed
    assert main(["snapshot", "export", "--session", "mov-f001", "--out", str(tmp_path / "one"),
                 *common]) == 0  # fmt: skip
    assert (tmp_path / "one" / "adaptive_cassi.mat").is_file()
    capsys.readouterr()


@pytest.mark.parametrize(
    ("command", "snapshot_id", "message"),
    [
        ("reconstruct", "mvo", "no snapshot 'mvo'"),
        ("export", "mvo", "no snapshot 'mvo'"),
        ("reconstruct", "mov-f007", "frame 'mov-f007' of snapshot 'mov' was not taken"),
        ("export", "mov-f007", "frame 'mov-f007' of snapshot 'mov' was not taken"),
    ],
)
def test_an_unknown_snapshot_id_is_one_line_naming_the_snapshots_there(
    taken, tmp_path, capsys, command, snapshot_id, message
):
    _, bundle, root, _ = taken
    status = main(
        ["snapshot", command, "--session", snapshot_id, "--bundle", str(bundle.path),
         "--data", str(root), "--out", str(tmp_path / "x")]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert status == 2 and message in err and err.count("\n") == 1, err
    assert "Session.create" not in err
    if "no snapshot" in message:
        assert "snapshots there: mov" in err
    assert not (tmp_path / "x").exists()


def test_a_session_folder_names_its_snapshot_in_its_own_data_root(taken, tmp_path):
    _, _, root, _ = taken
    frame = resolve_snapshot(str(root / "sessions" / "mov-f001"), data=tmp_path)
    assert (frame.prefix, frame.frames, frame.by_frame) == ("mov", (1,), True)
    video = resolve_snapshot(str(root / "sessions" / "mov-preview"), data=tmp_path)
    assert (video.frames, video.by_frame) == ((0, 1), False)
    assert resolve_snapshot("mov", data=tmp_path, required=False) is None
