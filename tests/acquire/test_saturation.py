"""Saturated and zero-clipped pixels are counted, said, and advised on."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.acquire.saturation import clipping, clipping_of_views


def test_fractions_of_a_known_frame():
    frame = np.full((10, 20), 1000, np.uint16)
    frame[:2] = 4095  # 40 of 200 pixels at full scale
    frame[9, :5] = 0  # 5 at zero
    found = clipping(frame, bit_depth=12, name="all open")
    assert found.saturated == pytest.approx(0.2) and found.zero == pytest.approx(0.025)
    assert found.brightest == 1.0 and not found.ok
    text = found.describe()
    assert text.startswith("all open: 20.0 % of pixels at full scale (4095 ADU), 2.5 % at zero")
    assert "Shorten the exposure" in text and "black level" in text


def test_a_well_exposed_frame_says_fine():
    frame = np.linspace(50, 3000, 400).reshape(20, 20).astype(np.uint16)
    found = clipping(frame, bit_depth=12)
    assert found.ok and found.advice() == ""
    assert found.describe().endswith("brightest 73 % of full scale: fine")


def test_a_colour_pixel_is_saturated_when_any_channel_is():
    frame = np.full((2, 2, 3), 100, np.uint8)
    frame[0, 0, 1] = 255
    frame[1, 1] = 0
    found = clipping(frame, bit_depth=8)
    assert found.saturated == 0.25 and found.zero == 0.25


def test_a_frame_of_the_wrong_shape_is_refused():
    with pytest.raises(ValueError, match="not \\(4,\\)"):
        clipping(np.zeros(4), bit_depth=8)


def test_the_quick_start_views_warn_about_the_saturated_all_open_frame():
    from sassi_bench import open_rig
    from sassi_bench.acquire.views import capture_views

    rig = open_rig("sim")
    views = capture_views(rig)
    found = {c.name: c for c in clipping_of_views(views, rig)}
    assert set(found) == {"guide", "spectral all open", "spectral pinholes"}
    assert found["spectral all open"].full_scale == 2**rig.spectral_camera.bit_depth - 1
    assert found["guide"].full_scale == 2**rig.guide_camera.bit_depth - 1
    # Measured on the sim rig: 63 % of the all-open frame at full scale.
    assert found["spectral all open"].saturated > 0.3 and not found["spectral all open"].ok
    # Stored frames (plain arrays) are named: a guide frame by its name.
    arrays = {"guide image": views["guide"].data, "pinholes": views["spectral_pinholes"].data}
    named = clipping_of_views(arrays, rig)
    expected = [found["guide"].full_scale, found["spectral pinholes"].full_scale]
    assert [c.full_scale for c in named] == expected


def test_a_well_that_fills_before_the_adc_is_found_on_a_bench_frame(tmp_path):
    """A camera built off its datasheet, its pixels filling at 90 % of the described well:
    an overexposed frame clips below full scale, where ``clip_level`` finds it."""
    from importlib import resources

    import yaml

    from sassi_bench import open_rig
    from sassi_bench.acquire.patterns import render_pattern
    from sassi_bench.acquire.saturation import clip_level

    rigs = resources.files("sassi_bench.procedures").joinpath("rigs")
    rig = yaml.safe_load(rigs.joinpath("sim.yaml").read_text())
    cam = rig["spectral_camera"]
    gain = cam["full_well_e"] / (2 ** cam["bit_depth"] - 1 - cam["dark_offset_adu"])
    rig.setdefault("as_built", {}).update(gain_e_per_adu=gain, full_well_e=0.9 * cam["full_well_e"])
    path = tmp_path / "low-well.yaml"
    path.write_text(yaml.safe_dump(rig))
    bench = open_rig(str(path))
    bench.slm.show(render_pattern({"kind": "full"}, bench.slm.shape))
    bench.light.select("laser:532")
    bench.spectral_camera.set_exposure(1.0)
    frame = bench.spectral_camera.capture().data
    clips_at = round(0.9 * cam["full_well_e"] / gain) + cam["dark_offset_adu"]
    assert frame.max() < 65535
    assert abs(clip_level(frame, 65535) - clips_at) <= 1
    assert np.count_nonzero(frame >= clip_level(frame, 65535)) > 100
    # A short exposure: its brightest pixel stands alone, and the full scale stands.
    bench.spectral_camera.set_exposure(0.01)
    short = bench.spectral_camera.capture().data
    assert 0.8 * 65535 > short.max() > 1000 and clip_level(short, 65535) == 65535
