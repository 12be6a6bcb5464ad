"""`sassi-bench snapshot live` on the sim rig: order kept, drops counted, Ctrl-C keeps frames."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr
import zarr

from sassi_bench.commands import main
from sassi_bench.procedure import load_procedure
from sassi_bench.rig.frame import Frame, FrameMeta
from sassi_bench.snapshot.video_store import VideoStore, read_frame
from sassi_bench.workflows import snapshot_live


class _Camera:
    def __init__(self, shape):
        self.shape, self.count = shape, 0

    def capture(self):
        self.count += 1
        data = np.full(self.shape, self.count, np.uint16)
        return Frame(data, FrameMeta("spectral", 0.1, 0.0, None, "led", self.count))


class _Trigger:
    armed = False

    def arm(self):
        self.armed = True

    def disarm(self):
        self.armed = False


class _Rig:
    def __init__(self):
        self.slm = type("Slm", (), {"show": lambda self, mask: 0})()
        self.guide_camera, self.spectral_camera = _Camera((4, 4, 3)), _Camera((8, 8))
        self.trigger = _Trigger()


def test_a_full_queue_drops_frames_counted_and_keeps_capture_order():
    plan = (np.zeros((2, 2), bool), np.zeros((0, 2), np.int32))
    capture = snapshot_live._Capture(_Rig(), "natural", None, plan, 6, None, size=2)
    capture.run()  # nobody reconstructs: the queue fills, the rest is dropped
    assert capture.error is None
    assert (capture.captured, capture.dropped, capture.queue.qsize()) == (6, 4, 2)
    assert not capture.rig.trigger.armed  # armed for the captures, left as found
    kept = [capture.queue.get_nowait() for _ in range(2)]
    assert [item.index for item in kept] == [0, 1]
    assert kept[0].time_s < kept[1].time_s


def test_live_on_sim_interrupted_keeps_every_captured_frame(guided_bundle, tmp_path, monkeypatch):
    rig, bundle, _, root = guided_bundle
    append = VideoStore.append

    def append_then_interrupt(self, *args, **kwargs):
        stored = append(self, *args, **kwargs)
        if stored == 2:
            raise KeyboardInterrupt  # Ctrl-C right after the second frame is stored
        return stored

    monkeypatch.setattr(VideoStore, "append", append_then_interrupt)
    # The kernels compile on a pipeline of their own before the capture starts, so no frame
    # is dropped while they do: the calls to process, by pipeline and capture started.
    calls: list[tuple[int, bool]] = []
    capturing: list[bool] = []
    process, capture = snapshot_live.VideoPipeline.process, snapshot_live._Capture._capture
    monkeypatch.setattr(
        snapshot_live.VideoPipeline, "process",
        lambda self, *a, **k: calls.append((id(self), bool(capturing))) or process(self, *a, **k),
    )  # fmt: skip
    monkeypatch.setattr(
        snapshot_live._Capture, "_capture", lambda self: capturing.append(True) or capture(self)
    )
    out = tmp_path / "live"
    with pytest.raises(KeyboardInterrupt):
        snapshot_live.run_live(
            rig, bundle, load_procedure("snapshot_validation"), scene="natural", out=out,
            frames=4, moving=True, progress=False,
        )  # fmt: skip
    group = zarr.open_group(str(out / "video.zarr"), mode="r")
    attrs = dict(group.attrs)
    assert attrs["stopped"] == "interrupted" and attrs["bundle_version"] == bundle.version
    assert attrs["frames"] >= 2 and attrs["frames"] + attrs["dropped"] == attrs["captured"]
    (warm, _), (live, _) = calls[0], calls[-1]
    assert calls[:2] == [(warm, False), (warm, False)] and warm != live
    assert all(started for _, started in calls[2:]) and len(calls) - 2 == attrs["frames"]
    index = group["frame_index"][: attrs["frames"]]
    assert np.all(np.diff(index) > 0) and np.all(np.diff(group["time_s"][: attrs["frames"]]) > 0)
    cube, _ = read_frame(out / "video.zarr", -1)
    assert cube.shape == (*bundle.slm_shape, bundle.wavelengths.size)
    assert float(cube.band(20).max()) > 0
    assert (out / "quicklook.gif").stat().st_size > 10_000
    # Any stored frame exports as a cube like a snapshot's.
    status = main(
        ["snapshot", "video-frame", "--video", str(out), "--frame", "1", "--out",
         str(tmp_path / "f1.nc"), "--bundle", str(bundle.path), "--data", str(root)]
    )  # fmt: skip
    assert status == 0
    with xr.open_dataset(tmp_path / "f1.nc") as ds:
        assert ds["radiance"].shape == cube.shape and ds.attrs["frame"] == 1
        np.testing.assert_allclose(
            ds["radiance"].values, read_frame(out / "video.zarr", 1)[0].dense()
        )
    assert (tmp_path / "f1.hdr").is_file()
