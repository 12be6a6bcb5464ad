"""The notebook's live view: its images update from the capture thread, Stop ends it and
frees the rig."""

from __future__ import annotations

import time

import cv2
import numpy as np
import pytest

from sassi_bench.notebook.live import LiveView
from sassi_bench.rig import load_rig_description, open_rig
from sassi_bench.workflows.live_view import alignment_feed
from sassi_bench.workflows.rig_lock import held_rigs

pytest.importorskip("ipywidgets")


def test_the_widget_updates_and_stops(tmp_path):
    rig = open_rig("sim")
    feed = alignment_feed(rig, ["laser:532"], live_exposure_s=0.05, max_fps=5)
    view = LiveView(feed, data=tmp_path, refresh_s=0.1).start()
    desc = load_rig_description("sim")
    try:
        assert held_rigs() == ("sim",)  # the live view holds the rig
        deadline = time.monotonic() + 300  # the first frame waits for kernels to compile
        while view.updates < 2:
            assert time.monotonic() < deadline, feed.status
            time.sleep(0.1)
    finally:
        view.button.click()  # what the Stop button does
    assert view.wait(timeout=120)
    assert not feed.running and view.button.disabled
    assert "stopped after" in view.status.value
    updates = view.updates
    time.sleep(0.5)
    assert view.updates == updates  # nothing updates after Stop
    png = view.images["spectral"].value
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    assert image.shape[:2] == (desc.spectral_camera.height, desc.spectral_camera.width)
    assert "full scale" in view.labels["spectral"].value
    assert held_rigs() == ()  # Stop freed the rig
    rig.close()
