import numpy as np
import pytest
import tifffile

from sassi_bench import open_rig
from sassi_bench.acquire.views import save_views
from sassi_bench.errors import SassiBenchError


def test_snapshot_writes_frames_and_never_overwrites(tmp_path):
    rig = open_rig("sim")
    files = save_views(rig, tmp_path, scene="white", light="laser:532")
    assert {f.name for f in files} == {
        "guide.png", "guide.tiff", "spectral_all_open.png", "spectral_all_open.tiff",
        "spectral_pinholes.png", "spectral_pinholes.tiff",
    }  # fmt: skip
    raw = tifffile.imread(tmp_path / "spectral_pinholes.tiff")
    assert raw.dtype == np.uint16 and raw.shape == (512, 800)
    assert raw.max() > 10 * np.median(raw)  # the pinholes' spots stand out
    before = (tmp_path / "guide.tiff").read_bytes()
    with pytest.raises(SassiBenchError, match="already exists"):
        save_views(rig, tmp_path, scene="white", light="laser:532")
    assert (tmp_path / "guide.tiff").read_bytes() == before


def test_snapshot_refuses_an_existing_image_before_capturing(tmp_path):
    import dataclasses

    rig = open_rig("sim")
    captured = []

    class Spy:
        def __init__(self, camera):
            self._camera = camera

        def __getattr__(self, name):
            return getattr(self._camera, name)

        def capture(self):
            captured.append(self._camera.name)
            return self._camera.capture()

    spied = dataclasses.replace(
        rig, spectral_camera=Spy(rig.spectral_camera), guide_camera=Spy(rig.guide_camera)
    )
    (tmp_path / "spectral_pinholes.png").write_bytes(b"an earlier image")
    with pytest.raises(SassiBenchError, match=r"spectral_pinholes\.png already exists"):
        save_views(spied, tmp_path, scene="white", light="led")
    assert captured == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["spectral_pinholes.png"]
