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


def _lamp_rig(tmp_path, full_well_scale: float = 1.0):
    """``sim`` with its lamps; the bench's pixels fill at ``full_well_scale`` of the
    described well (its ADC's full scale)."""
    from importlib import resources

    import yaml

    rigs = resources.files("sassi_bench.procedures").joinpath("rigs")
    rig = yaml.safe_load(rigs.joinpath("sim.yaml").read_text())
    cam = rig["spectral_camera"]
    gain = cam["full_well_e"] / (2 ** cam["bit_depth"] - 1 - cam["dark_offset_adu"])
    as_built = rig.setdefault("as_built", {})
    as_built.update(gain_e_per_adu=gain, full_well_e=cam["full_well_e"] * full_well_scale)
    path = tmp_path / "lamp-rig.yaml"
    path.write_text(yaml.safe_dump(rig))
    return open_rig(str(path)), round(cam["full_well_e"] * full_well_scale / gain) + cam[
        "dark_offset_adu"
    ]


def test_a_lamp_exposure_reads_its_brightest_line_off_its_pinholes(tmp_path):
    from sassi_bench.acquire.patterns import open_pixels
    from sassi_bench.acquire.spectral_plans import lamp_pinholes

    rig, _ = _lamp_rig(tmp_path)
    pattern = lamp_pinholes({"lamps": {"pinhole_pitch_px": [100, 24]}})
    pinholes = int(open_pixels(pattern, tuple(rig.slm.shape))[0].size)
    auto_exposure(rig, "lamp:HgAr", pattern, target_fraction=0.6, start_s=0.05, max_s=10.0,
                  bright_pixels=pinholes)  # fmt: skip
    frame = rig.spectral_camera.capture().data.ravel()
    # As many of the brightest pixels as there are pinholes: about the median pinhole's
    # brightest line, at the target; the brightest pinhole's well below full scale.
    assert np.sort(frame)[-pinholes] / 65535 == pytest.approx(0.6, abs=0.08)
    assert frame.max() / 65535 < 0.9


def test_a_well_that_fills_before_the_adc_is_found_and_avoided(tmp_path):
    from sassi_bench.acquire.saturation import clip_level

    rig, clips_at = _lamp_rig(tmp_path, full_well_scale=0.9)
    rig.slm.show(render_pattern({"kind": "full"}, rig.slm.shape))
    rig.light.select("laser:532")
    rig.spectral_camera.set_exposure(1.0)
    frame = rig.spectral_camera.capture().data
    assert frame.max() < 65535 and abs(clip_level(frame, 65535) - clips_at) <= 1
    auto_exposure(rig, "laser:532", {"kind": "full"}, target_fraction=0.95, start_s=1.0)
    frame = rig.spectral_camera.capture().data
    assert frame.max() < clips_at  # halved out of the clipped frames
