import numpy as np
import pytest

from sassi_bench import open_rig
from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.errors import DeviceError


def test_auto_exposure_reaches_the_target_level():
    rig = open_rig("sim")
    pattern = {"kind": "full"}
    exposure = auto_exposure(rig, "laser:532", pattern, target_fraction=0.5)
    rig.slm.show(render_pattern(pattern, rig.slm.shape))
    frame = rig.spectral_camera.capture().data
    level = np.percentile(frame, 99.95) / 65535
    assert rig.spectral_camera.exposure_s == exposure
    assert level == pytest.approx(0.5, abs=0.08)
    assert frame.max() < 65535


def test_no_light_is_a_clear_error():
    rig = open_rig("sim")
    with pytest.raises(DeviceError, match="check that the light is on"):
        auto_exposure(rig, "off", {"kind": "full"}, max_s=0.05)
