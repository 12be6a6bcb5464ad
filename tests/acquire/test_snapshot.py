import numpy as np
import pytest
import tifffile

from sassi_bench import open_rig
from sassi_bench.acquire.snapshot import take_snapshot
from sassi_bench.errors import SassiBenchError


def test_snapshot_writes_frames_and_never_overwrites(tmp_path):
    rig = open_rig("sim")
    files = take_snapshot(rig, tmp_path, scene="white", light="laser:532")
    assert {f.name for f in files} == {
        "guide.png", "guide.tiff", "spectral_all_open.png", "spectral_all_open.tiff",
        "spectral_pinholes.png", "spectral_pinholes.tiff",
    }  # fmt: skip
    raw = tifffile.imread(tmp_path / "spectral_pinholes.tiff")
    assert raw.dtype == np.uint16 and raw.shape == (512, 800)
    assert raw.max() > 10 * np.median(raw)  # the pinholes' spots stand out
    before = (tmp_path / "guide.tiff").read_bytes()
    with pytest.raises(SassiBenchError, match="already exists"):
        take_snapshot(rig, tmp_path, scene="white", light="laser:532")
    assert (tmp_path / "guide.tiff").read_bytes() == before
