"""The live view's server on the sim rig: the token, a frame of the camera's size whose
clipped pixels are the frame's, rates above zero."""

from __future__ import annotations

import json
import time
import urllib.error
import urllib.request

import cv2
import numpy as np
import pytest

from sassi_bench.acquire.live_feed import LatestFrame
from sassi_bench.acquire.live_render import SATURATED_RGB, ZERO_RGB
from sassi_bench.acquire.saturation import clipping
from sassi_bench.errors import ProcedureError
from sassi_bench.rig import open_rig
from sassi_bench.workflows.live_view import LiveServer, alignment_feed
from sassi_bench.workflows.rig_lock import driving


class RecordingSlot(LatestFrame):
    """A one-slot buffer that also keeps every frame by number (for the test to compare)."""

    def __init__(self) -> None:
        super().__init__()
        self.kept = {}

    def put(self, frame) -> None:
        self.kept[frame.seq] = frame
        super().put(frame)


def get(url: str) -> tuple[int, bytes, dict[str, str]]:
    try:
        with urllib.request.urlopen(url, timeout=30) as answer:
            return answer.status, answer.read(), dict(answer.headers)
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read(), dict(exc.headers)


def status_of(server) -> dict:
    status, body, _ = get(f"{base(server)}/status.json?token={server.token}")
    assert status == 200
    return json.loads(body)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    rig = open_rig("sim")
    # A long live exposure: the pinholes' spots saturate, so the clipped share is not 0.
    feed = alignment_feed(rig, ["laser:532"], live_exposure_s=2.0, readings_every_s=1.0)
    slot = feed.latest["spectral"] = RecordingSlot()
    data = tmp_path_factory.mktemp("data")
    with driving(rig, data, "live test"), feed, LiveServer(feed, port=0) as running:
        # The first frame waits for the virtual bench's kernels to compile (a minute on a
        # loaded machine): a wait for readiness, not a timing assertion.
        assert slot.wait_newer(-1, timeout=300) is not None, feed.status
        yield running
    rig.close()


def base(server) -> str:
    return f"http://127.0.0.1:{server.port}"


def test_requests_without_the_token_are_refused(server):
    for path in ("/", "/status.json", "/frame/spectral.png", "/frame/spectral.png?token=x"):
        status, body, _ = get(base(server) + path)
        assert status == 403, path
        assert b"token" in body
    status, body, _ = get(server.url)
    assert status == 200 and b"live view" in body
    assert server.url.startswith("http://127.0.0.1:")


def test_a_frame_has_the_camera_size_and_its_clipped_pixels(server):
    status, png, headers = get(f"{base(server)}/frame/spectral.png?token={server.token}")
    assert status == 200
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)[..., ::-1]
    camera = server.feed.rig.spectral_camera
    desc = server.feed.rig.description.spectral_camera
    assert image.shape == (desc.height, desc.width, 3)
    raw = server.feed.latest["spectral"].kept[int(headers["X-Seq"])].data
    truth = clipping(raw, bit_depth=camera.bit_depth)
    assert truth.saturated > 0  # the long exposure saturates the spots' cores
    assert float(headers["X-Saturated"]) == truth.saturated
    assert float(headers["X-Zero"]) == truth.zero
    red = np.all(image == SATURATED_RGB, axis=-1).mean()
    blue = np.all(image == ZERO_RGB, axis=-1).mean()
    assert red == pytest.approx(truth.saturated, abs=0.5 / raw.size)
    assert blue == pytest.approx(truth.zero, abs=0.5 / raw.size)


def test_the_status_reports_rates_and_readings(server):
    deadline = time.monotonic() + 40
    while not status_of(server)["readings"]:
        assert time.monotonic() < deadline, status_of(server)["status"]
        time.sleep(0.5)
    seq = -1
    for _ in range(4):  # a viewer taking each next frame, as the page does
        url = f"{base(server)}/frame/guide.png?token={server.token}&after={seq}"
        _, _, headers = get(url + "&latency=0.05&fps=3")
        seq = int(headers["X-Seq"])
    found = status_of(server)
    assert found["status"] == "live"
    spectral, guide = found["cameras"]["spectral"], found["cameras"]["guide"]
    assert spectral["capture_fps"] > 0 and guide["capture_fps"] > 0
    assert guide["served_fps"] > 0 and guide["served_latency_ms"] >= 0
    assert guide["display_latency_ms"] == pytest.approx(50)  # what the page reported
    assert len(spectral["histogram"]) == 64
    assert sum(guide["histogram"]) == int(np.prod(guide["shape"])) * 3
    names = [reading["name"] for reading in found["readings"]]
    assert "footprint 532 nm" in names and "spot width 532 nm" in names
    corners = next(r["corners"] for r in found["readings"] if "corners" in r)
    assert np.asarray(corners).shape == (4, 2)


def test_a_port_in_use_is_a_clear_error(server):
    with pytest.raises(ProcedureError, match=r"cannot serve on 127\.0\.0\.1.*give another --port"):
        LiveServer(server.feed, port=server.port)
