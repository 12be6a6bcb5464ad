"""GenICam adapter: discovery and streaming on the genicam wheel's producer; exposure
and trigger logic on fake nodes (that producer has neither)."""

import sys

import numpy as np
import pytest

from sassi_bench.errors import DeviceError
from sassi_bench.rig.hardware.genicam import GenICamCamera, open_genicam

fake = sys.modules["sassi_bench_test_fake_genicam"]  # loaded by tests/rig/conftest.py


def test_discovery_features_and_frames_on_the_producer(viky_cti):
    camera = open_genicam("guide", viky_cti, {"serial_number": "2"}, pixel_format="Mono8")
    try:
        node_map = camera._nm
        assert (node_map.Width.value, node_map.Height.value) == (400, 400)
        node_map.Width.value, node_map.Height.value = 128, 104
        assert camera.shape == (400, 400)  # taken when opened
        assert camera.bit_depth == 8 and camera.trigger == "none"
        assert camera.exposure_range_s == (0.0, 0.0)  # no ExposureTime: fixed
        camera.set_exposure(0.0)
        with pytest.raises(ValueError, match=r"outside the camera's range \[0, 0\] s"):
            camera.set_exposure(0.01)
    finally:
        camera.close()
    camera = open_genicam("guide", [viky_cti], 0, pixel_format="RGBa8")
    try:
        first, second = camera.capture(), camera.capture()
        assert first.shape == (400, 400, 3) and first.data.dtype == np.uint8
        assert first.meta.extra == {"pixel_format": "RGBa8"}
        assert second.meta.index == 1
        assert first.data.std() > 0  # the producer draws a picture, not a constant
    finally:
        camera.close()


def test_discovery_errors_name_the_fix(viky_cti, tmp_path):
    with pytest.raises(DeviceError, match=r"GenTL producer .* does not exist\. Fix: install"):
        open_genicam("guide", str(tmp_path / "FLIR_GenTL.cti"))
    with pytest.raises(DeviceError, match=r"no camera matches .*Fix: choose one of: 0: Viky"):
        open_genicam("guide", viky_cti, {"serial_number": "12345"})
    with pytest.raises(DeviceError, match=r"PixelFormat cannot be 'Mono16'\. Fix: use one of"):
        open_genicam("guide", viky_cti, 0, pixel_format="Mono16")


def make_camera(trigger="auto", **nodes):
    node_map = fake.LayeredNodeMap(
        None,
        Width=fake.FakeNode(6),
        Height=fake.FakeNode(4),
        PixelFormat=fake.FakeNode("Mono12", symbolics=("Mono8", "Mono12")),
        **nodes,
    )
    acquirer = fake.FakeAcquirer(node_map)
    camera = GenICamCamera(
        "spectral", acquirer, trigger=trigger, state=lambda: (5, "led"), timeout_s=0.5
    )
    return camera, acquirer, node_map


def test_exposure_in_microseconds_with_the_nodes_range():
    camera, _, nodes = make_camera(**fake.exposure_nodes(lo_us=20.0, hi_us=2e6, value_us=5000.0))
    assert camera.exposure_range_s == (2e-5, 2.0)
    assert camera.exposure_s == pytest.approx(0.005)
    assert nodes.ExposureAuto.value == "Off"
    camera.set_exposure(0.25)
    assert nodes.ExposureTime.value == pytest.approx(250000.0)
    with pytest.raises(ValueError, match=r"outside the camera's range \[2e-05, 2\] s"):
        camera.set_exposure(3.0)
    assert nodes.ExposureTime.writes == [pytest.approx(250000.0)]
    assert camera.bit_depth == 12 and camera.shape == (4, 6)


def test_line_trigger_configures_frame_start_and_streams():
    camera, acquirer, nodes = make_camera("line", **fake.exposure_nodes(), **fake.trigger_nodes())
    assert nodes.TriggerSelector.value == "FrameStart"
    assert nodes.TriggerSource.value == "Line0"
    assert nodes.TriggerActivation.value == "RisingEdge"
    assert nodes.TriggerMode.writes == ["Off", "On"]  # off while the selector changes
    frames = [camera.capture()]
    acquirer.buffered = 3  # the SLM kept pulsing between captures
    frames.append(camera.capture())
    assert acquirer.starts == 1 and acquirer.stops == 0  # streams, waits for pulses
    # first: frame 1 dropped (may predate the call), 2 returned; second: 3-5 buffered
    # and given back, 6 dropped, 7 returned
    assert [int(f.data[0, 0]) for f in frames] == [2, 7]
    assert acquirer.requeued == 3
    assert frames[0].meta.pattern_id == 5 and frames[0].meta.light == "led"
    assert nodes.TriggerSoftware.executed == 0
    camera.close()
    assert acquirer.stops == 1 and acquirer.destroyed


def test_software_trigger_fires_once_per_capture():
    camera, acquirer, nodes = make_camera(**fake.exposure_nodes(), **fake.trigger_nodes())
    assert camera.trigger == "software" and nodes.TriggerSource.value == "Software"
    camera.capture()
    camera.capture()
    assert nodes.TriggerSoftware.executed == 2 and acquirer.fetched == 2


def test_untriggered_camera_restarts_per_frame():
    camera, acquirer, _ = make_camera(**fake.exposure_nodes())
    assert camera.trigger == "none"
    camera.capture()
    camera.capture()
    assert acquirer.starts == acquirer.stops == 2  # never returns a frame from before


def test_trigger_and_format_errors():
    with pytest.raises(DeviceError, match="needs TriggerMode, which the camera lacks"):
        make_camera("line", **fake.exposure_nodes())
    with pytest.raises(DeviceError, match="unknown trigger 'hw'"):
        make_camera("hw", **fake.exposure_nodes(), **fake.trigger_nodes())
    nodes = fake.LayeredNodeMap(
        None, Width=fake.FakeNode(6), Height=fake.FakeNode(4), PixelFormat=fake.FakeNode("YUV422")
    )
    with pytest.raises(DeviceError, match="pixel format 'YUV422' is not supported"):
        GenICamCamera("guide", fake.FakeAcquirer(nodes))
    with pytest.raises(DeviceError, match="has no Height feature"):
        GenICamCamera(
            "guide",
            fake.FakeAcquirer(fake.LayeredNodeMap(None, PixelFormat=fake.FakeNode("Mono8"))),
        )
