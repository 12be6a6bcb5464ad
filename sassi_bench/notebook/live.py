"""The live view in a notebook: both cameras, their clipped pixels and the alignment readings.

The same feed as ``sassi-bench align`` (:func:`~sassi_bench.workflows.live_view.alignment_feed`,
a capture thread filling a one-slot buffer per camera) drives two ``ipywidgets.Image``
widgets and their labels from a second thread, which takes the newest frame whenever it is
ready for one: a slow browser drops frames (counted), never captures. The rig's lock is
held while the view runs; the Stop button (or :meth:`LiveView.stop`) frees it.

Examples
--------
Not run here (it needs a bench, captured sessions or files)::

    live = live_view(rig, lights=["laser:532"], seconds=15)
    live.wait()  # the cells below get the rig back when it stops
"""

from __future__ import annotations

import contextlib
import html
import os
import threading
import time
from collections.abc import Sequence
from typing import Any

from sassi_bench.acquire.live_feed import CAMERAS, LiveFeed, RateMeter
from sassi_bench.acquire.live_render import encode_png, overlay_rgb
from sassi_bench.acquire.saturation import clipping
from sassi_bench.workflows.live_view import alignment_feed
from sassi_bench.workflows.rig_lock import driving

__all__ = ["LiveView", "live_view"]


class LiveView:
    """Live images of a rig's cameras with their figures and the readings, in widgets.

    Parameters
    ----------
    feed
        The live feed (not started; :meth:`start` starts it).
    data
        The data root (for the rig's lock).
    refresh_s
        The least time between two updates of the widgets.

    Attributes
    ----------
    widget
        The ``ipywidgets.VBox`` to display.
    updates
        How many times the images were updated.
    dropped
        Per camera, the frames captured that the view never showed.
    """

    def __init__(
        self,
        feed: LiveFeed,
        *,
        data: str | os.PathLike[str] | None = None,
        refresh_s: float = 0.2,
    ) -> None:
        import ipywidgets as widgets

        self.feed = feed
        self.data = data
        self.refresh_s = refresh_s
        self.updates = 0
        self.dropped = dict.fromkeys(CAMERAS, 0)
        self.shown = {camera: RateMeter() for camera in CAMERAS}
        self.images = {
            camera: widgets.Image(format="png", layout=widgets.Layout(width="420px"))
            for camera in CAMERAS
        }
        self.labels = {camera: widgets.HTML() for camera in CAMERAS}
        self.readings = widgets.HTML("<i>waiting for the first readings round</i>")
        self.status = widgets.HTML()
        self.button = widgets.Button(description="Stop", button_style="danger", icon="stop")
        self.button.on_click(lambda _: self.stop())
        columns = [
            widgets.VBox([widgets.HTML(f"<b>{camera} camera</b>"), self.images[camera], label])
            for camera, label in self.labels.items()
        ]
        self.widget = widgets.VBox(
            [widgets.HBox([self.button, self.status]), widgets.HBox(columns), self.readings]
        )
        self._stop = threading.Event()
        self._stopped = threading.Event()
        self._lock = contextlib.ExitStack()
        self._thread: threading.Thread | None = None

    def start(self, seconds: float | None = None) -> LiveView:
        """Take the rig's lock, start the feed and the updates; stop after ``seconds``
        when given."""
        self._lock.enter_context(driving(self.feed.rig, self.data, "live view"))
        self.feed.start()
        self._thread = threading.Thread(target=self._update_loop, name="live-widget", daemon=True)
        self._thread.start()
        if seconds is not None:
            threading.Timer(seconds, self.stop).start()
        return self

    def stop(self) -> None:
        """Stop the updates and the feed and free the rig (safe to call twice)."""
        if self._stop.is_set():
            self._stopped.wait(60)
            return
        self._stop.set()
        if self._thread is not None:
            self._thread.join(10)
        self.feed.stop()
        self._lock.close()
        self.button.disabled = True
        self.status.value = f"stopped after {self.updates} updates" + (
            f": {html.escape(str(self.feed.error))}" if self.feed.error else ""
        )
        self._stopped.set()

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the view has stopped; whether it has."""
        return self._stopped.wait(timeout)

    def _update_loop(self) -> None:
        seqs = dict.fromkeys(CAMERAS, -1)
        while not self._stop.is_set() and self.feed.running:
            start = time.monotonic()
            updated = False
            for camera in CAMERAS:
                frame = self.feed.latest[camera].wait_newer(seqs[camera], timeout=0.05)
                if frame is None:
                    continue
                if seqs[camera] >= 0:
                    self.dropped[camera] += frame.seq - seqs[camera] - 1
                seqs[camera] = frame.seq
                self.images[camera].value = encode_png(
                    overlay_rgb(frame.data, bit_depth=frame.bit_depth)
                )
                self.shown[camera].tick()
                self.labels[camera].value = self._figures(camera, frame)
                updated = True
            self.updates += updated
            self.status.value = html.escape(f"{self.feed.rig.description.name}: {self.feed.status}")
            self._show_readings()
            self._stop.wait(max(0.0, self.refresh_s - (time.monotonic() - start)))
        if not self._stop.is_set():  # the feed stopped by itself (an error)
            threading.Thread(target=self.stop, daemon=True).start()

    def _figures(self, camera: str, frame: Any) -> str:
        clip = clipping(frame.data, bit_depth=frame.bit_depth, name=camera)
        latency_ms = 1000 * (time.time() - frame.captured_at)
        return (
            f"<tt>frame {frame.seq}: shown {self.shown[camera].rate():.1f} fps (captured "
            f"{self.feed.captured[camera].rate():.1f} fps), dropped {self.dropped[camera]}, "
            f"latency {latency_ms:.0f} ms<br>full scale {100 * clip.saturated:.2f} % "
            f"(<span style='color:#f00'>red</span>), zero {100 * clip.zero:.2f} % "
            f"(<span style='color:#00f'>blue</span>)</tt>"
        )

    def _show_readings(self) -> None:
        readings = self.feed.readings
        if readings is None:
            return
        rows = []
        for reading in readings.values:
            if not hasattr(reading, "ok"):
                rows.append(f"<tr><td colspan=5>{html.escape(str(reading))}</td></tr>")
                continue
            mark = (
                "<b style='color:#1a7f37'>ok</b>"
                if reading.ok
                else "<b style='color:#b3261e'>TURN</b>"
            )
            cells = (reading.name, reading.value, reading.target, reading.advice)
            rows.append(
                f"<tr><td>{mark}</td>"
                + "".join(f"<td>{html.escape(c)}</td>" for c in cells)
                + "</tr>"
            )
        age = time.time() - readings.ready_at
        self.readings.value = (
            f"<b>alignment readings</b> ({age:.0f} s old, read in {readings.processing_s:.1f} s)"
            f"<table>{''.join(rows)}</table>"
        )


def live_view(
    rig: Any,
    lights: Sequence[str] | None = None,
    *,
    data: str | os.PathLike[str] | None = None,
    seconds: float | None = None,
    live_exposure_s: float | None = None,
    max_fps: float = 5.0,
) -> LiveView:
    """Show ``rig``'s live view in the notebook and start it.

    Parameters
    ----------
    rig
        The rig (``open_rig(...)``).
    lights
        The reading lights (default: every laser; with lights the operator switches, one).
    data
        The data root (for the rig's lock).
    seconds
        Stop by itself after this long (a notebook run unattended); ``None``: until Stop.
    live_exposure_s
        The live frames' exposure (default: auto-exposure's).
    max_fps
        The most live frames a second.

    Returns
    -------
    LiveView
        Started and displayed; ``stop()`` or the Stop button ends it.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        live = live_view(open_rig("sim"), lights=["laser:532"])
    """
    from IPython.display import display

    feed = alignment_feed(rig, lights, max_fps=max_fps, live_exposure_s=live_exposure_s)
    view = LiveView(feed, data=data)
    display(view.widget)
    return view.start(seconds)
