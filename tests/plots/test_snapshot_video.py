"""The quick-look GIF of a snapshot video: every frame, its panels captioned."""

from types import SimpleNamespace

import numpy as np

from sassi_bench.plots.snapshot_video import CAPTION_PX, video_animation
from sassi_bench.snapshot.factored import Rank1Cube
from sassi_bench.snapshot.video_store import VideoStore

WAV = np.linspace(420.0, 680.0, 14)


def _store(path, frames=3, h=40, w=160):
    edges = np.concatenate([[410.0], (WAV[:-1] + WAV[1:]) / 2, [690.0]])
    bundle = SimpleNamespace(
        slm_shape=(h, w), wavelengths=WAV, bin_edges=edges, rig_name="sim", version="v0001"
    )
    store = VideoStore(path, bundle, units="relative photon radiance per bin")
    rng = np.random.default_rng(0)
    for t in range(frames):
        labels = (np.arange(h * w).reshape(h, w) // 7) % 4
        cube = Rank1Cube(
            labels.astype(np.intp),
            rng.uniform(0.5, 1.5, (h, w)).astype(np.float32),
            rng.uniform(0.0, 1.0, (4, WAV.size)).astype(np.float32),
        )
        store.append(cube, np.zeros((h, w), bool), time_s=0.05 * t, frame_index=t)
    return path


def test_the_gif_holds_every_frame_with_a_caption_over_each_panel(tmp_path):
    import imageio.v2 as imageio

    gif = video_animation(_store(tmp_path / "video.zarr"), tmp_path / "look.gif", step=1)
    frames = imageio.mimread(gif)
    assert len(frames) == 3
    first = np.asarray(frames[0])[..., :3]
    assert first.shape[:2] == (40 + CAPTION_PX, 2 * 160)
    text = first[:CAPTION_PX].min(axis=2) > 128  # white on black
    # Text in both halves of the strip: the sRGB panel and the band.
    assert text[:, :160].sum() > 20 and text[:, 160:].sum() > 20
    # The frame number changes from frame to frame; the band's caption does not.
    second = np.asarray(frames[1])[:CAPTION_PX, :, :3].min(axis=2) > 128
    assert not np.array_equal(text[:, :160], second[:, :160])
    assert np.array_equal(text[:, 160:], second[:, 160:])
