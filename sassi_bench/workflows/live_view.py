"""The live view: both cameras live in a browser page, with the alignment readings.

:func:`alignment_feed` makes the feed (:class:`~sassi_bench.acquire.live_feed.LiveFeed`):
the alignment pattern on the SLM (sparse pinholes), live frames under one light, and every
few seconds a readings round under each reading light, read by
:func:`~sassi_bench.reduce.alignment.alignment_readings`. :class:`LiveServer` serves it to
a page on the loopback interface only, behind a random token in the address (as
Jupyter's server is): a request without the token gets 403. The page asks for the newest
frame of each camera as soon as it has shown the last one, so a slow browser drops frames
(counted) and never slows the captures. :func:`serve_live` holds the rig's lock while it
serves; Ctrl-C or SIGTERM stops it, the devices left as found.

Examples
--------
Not run here (it needs a bench, captured sessions or files)::

    from sassi_bench import open_rig
    serve_live(open_rig("sim"), port=0, on_ready=print)  # prints the address; Ctrl-C stops
"""

from __future__ import annotations

import contextlib
import functools
import hmac
import json
import os
import secrets
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any
from urllib.parse import parse_qs, urlsplit

import numpy as np

from sassi_bench.acquire.live_feed import CAMERAS, LiveFeed, LiveFrame, RateMeter
from sassi_bench.acquire.live_render import encode_png, histogram, overlay_rgb
from sassi_bench.acquire.saturation import clipping
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.alignment import Reading, alignment_pattern, alignment_readings
from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.align import alignment_lights
from sassi_bench.workflows.rig_lock import driving

__all__ = ["LiveServer", "alignment_feed", "live_status", "serve_live"]

#: The interface the page is served on: this machine only.
LOOPBACK = "127.0.0.1"
#: A viewer that asked for no frame for this long had gone (a closed tab): the frames
#: captured meanwhile are not counted as dropped.
VIEWER_GONE_S = 2.0


def alignment_feed(
    rig: Rig,
    lights: Sequence[str] | None = None,
    *,
    live_light: str | None = None,
    readings_every_s: float = 3.0,
    max_fps: float = 10.0,
    live_exposure_s: float | None = None,
) -> LiveFeed:
    """A live feed of ``rig`` under the alignment pattern, with the alignment readings.

    Parameters
    ----------
    rig
        The rig.
    lights
        The reading lights (default: every laser, as ``sassi-bench align``); on a bench
        whose lights the operator switches, name one (each switch asks the operator).
    live_light
        The light of the live frames (default: the reading light nearest the prism's
        reference wavelength, whose frame gives the footprint).
    readings_every_s, max_fps, live_exposure_s
        As :class:`~sassi_bench.acquire.live_feed.LiveFeed`.

    Returns
    -------
    LiveFeed
        Not started.

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> alignment_feed(open_rig("sim")).live_light
    'laser:532'
    """
    desc = rig.description
    pattern = alignment_pattern(desc)
    names = alignment_lights(rig, lights)
    if live_light is None:
        live_light = min(names, key=lambda name: _distance_nm(name, desc.prism.reference_nm))
    bit_depth = rig.spectral_camera.bit_depth

    def analyse(frames: dict[str, Any]) -> list[Reading]:
        return alignment_readings(desc, pattern, frames, bit_depth)

    return LiveFeed(
        rig,
        lights=names,
        pattern=pattern,
        analyse=analyse,
        live_light=live_light,
        readings_every_s=readings_every_s,
        max_fps=max_fps,
        live_exposure_s=live_exposure_s,
    )


def _distance_nm(light: str, reference_nm: float) -> float:
    """How far a laser's line is from ``reference_nm``; other lights come last."""
    kind, _, nm = light.partition(":")
    return abs(float(nm) - reference_nm) if kind == "laser" else float("inf")


def _frame_figures(frame: LiveFrame) -> dict[str, Any]:
    clip = clipping(frame.data, bit_depth=frame.bit_depth, name=frame.camera)
    return {
        "seq": frame.seq,
        "shape": list(frame.data.shape[:2]),
        "light": frame.light,
        "saturated": clip.saturated,
        "zero": clip.zero,
        "brightest": clip.brightest,
        "histogram": histogram(frame.data, bit_depth=frame.bit_depth),
        "clipping": clip.describe(),
    }


def _reading_json(reading: Any) -> dict[str, Any]:
    if not isinstance(reading, Reading):
        return {"name": "readings", "value": "", "target": "", "ok": False, "advice": str(reading)}
    out = {
        "name": reading.name,
        "value": reading.value,
        "target": reading.target,
        "ok": bool(reading.ok),
        "advice": reading.advice,
    }
    if reading.name.startswith("footprint") and len(reading.numbers) >= 8:
        corners = np.asarray(reading.numbers[:8], dtype=float).reshape(4, 2)
        out["corners"] = corners.tolist()
    return out


class _Shown:
    """What the viewers were served of one camera: the PNG of its newest frame (encoded
    once, whoever asks), the rate, the frames dropped between two served frames and the
    capture-to-served and capture-to-display latencies."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.encoded: tuple[int, bytes, dict[str, Any], float] | None = None
        self.served = RateMeter()
        self.last_seq = -1
        self.last_served = 0.0
        self.dropped = 0
        self.served_latency_s: list[float] = []
        self.display_latency_s: list[float] = []
        self.display_fps = 0.0

    def encode(self, frame: LiveFrame) -> tuple[bytes, dict[str, Any]]:
        with self.lock:
            if self.encoded is None or self.encoded[0] != frame.seq:
                png = encode_png(overlay_rgb(frame.data, bit_depth=frame.bit_depth))
                self.encoded = (frame.seq, png, _frame_figures(frame), frame.captured_at)
            _, png, figures, _ = self.encoded
            if frame.seq > self.last_seq:
                now = time.monotonic()
                if self.last_seq >= 0 and now - self.last_served < VIEWER_GONE_S:
                    self.dropped += frame.seq - self.last_seq - 1
                self.last_seq, self.last_served = frame.seq, now
                self.served.tick()
                _keep_last(self.served_latency_s, time.time() - frame.captured_at)
            return png, figures


@functools.cache
def _page() -> str:
    """The page (``live_view.html`` beside this module)."""
    return (Path(__file__).with_name("live_view.html")).read_text(encoding="utf-8")


def _keep_last(values: list[float], value: float, n: int = 30) -> None:
    values.append(value)
    del values[:-n]


def _mean_ms(values: list[float]) -> float | None:
    return round(1000 * sum(values) / len(values), 1) if values else None


def live_status(feed: LiveFeed, shown: dict[str, _Shown] | None = None) -> dict[str, Any]:
    """The live view's figures, as the page shows them (JSON-ready).

    Per camera: the capture rate, the newest frame's clipping and histogram, and, for
    what a server served (``shown``), the served and displayed rates, the frames dropped
    and the latencies; then the readings and how old they are.

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> live_status(alignment_feed(open_rig("sim")))["status"]
    'not started'
    """
    cameras = {}
    for name in CAMERAS:
        frame = feed.latest[name].peek()
        entry: dict[str, Any] = {"capture_fps": round(feed.captured[name].rate(), 2)}
        if shown is not None:
            seen = shown[name]
            with seen.lock:
                figures = seen.encoded[2] if seen.encoded else None
                entry |= {
                    "served_fps": round(seen.served.rate(), 2),
                    "display_fps": round(seen.display_fps, 2),
                    "dropped": seen.dropped,
                    "served_latency_ms": _mean_ms(seen.served_latency_s),
                    "display_latency_ms": _mean_ms(seen.display_latency_s),
                }
        else:
            figures = _frame_figures(frame) if frame is not None else None
        if figures is not None:
            entry |= figures
        cameras[name] = entry
    readings = feed.readings
    return {
        "rig": feed.rig.description.name,
        "status": feed.status,
        "live_light": feed.live_light,
        "cameras": cameras,
        "readings": [_reading_json(r) for r in readings.values] if readings else [],
        "readings_age_s": round(time.time() - readings.ready_at, 1) if readings else None,
        "readings_s": round(readings.processing_s, 2) if readings else None,
    }


class LiveServer:
    """A live feed served to a browser page on the loopback interface, behind a token.

    Parameters
    ----------
    feed
        The (started) feed.
    port
        The port; 0 takes a free one.
    token
        The secret the address carries (default: a new random one).

    Attributes
    ----------
    url
        The page's address, token included.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        with LiveServer(feed.start(), port=0) as server:
            print(server.url)
    """

    def __init__(self, feed: LiveFeed, *, port: int = 0, token: str | None = None) -> None:
        self.feed = feed
        self.token = token or secrets.token_urlsafe(24)
        self.shown = {name: _Shown() for name in CAMERAS}
        try:
            self._httpd = ThreadingHTTPServer((LOOPBACK, port), _handler(self))
        except OSError as exc:
            raise ProcedureError(
                step_error(
                    "live view",
                    f"cannot serve on {LOOPBACK}:{port} ({exc.strerror or exc})",
                    "give another --port, or 0 for a free one",
                )
            ) from exc
        self._httpd.daemon_threads = True
        self.port = self._httpd.server_address[1]
        self.url = f"http://{LOOPBACK}:{self.port}/?token={self.token}"
        self._thread: threading.Thread | None = None

    def start(self) -> LiveServer:
        """Serve on a thread; returns the server."""
        self._thread = threading.Thread(
            target=self._httpd.serve_forever, kwargs={"poll_interval": 0.2}, daemon=True
        )
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close the socket."""
        if self._thread is not None:
            self._httpd.shutdown()
            self._thread.join(5)
            self._thread = None
        self._httpd.server_close()

    def __enter__(self) -> LiveServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def allowed(self, query: dict[str, list[str]]) -> bool:
        """Whether a request carries the token (compared in constant time)."""
        given = query.get("token", [""])[0]
        return hmac.compare_digest(given.encode(), self.token.encode())


def _handler(server: LiveServer) -> type[BaseHTTPRequestHandler]:
    class Handler(BaseHTTPRequestHandler):
        def log_message(self, format: str, *args: Any) -> None:
            pass  # the terminal shows the address and the stop hint, not every request

        def do_GET(self) -> None:
            parts = urlsplit(self.path)
            query = parse_qs(parts.query)
            if not server.allowed(query):
                self._send(
                    HTTPStatus.FORBIDDEN,
                    b"live view: this address needs the token printed when the view started "
                    b"(open the full address, ?token=... included)\n",
                    "text/plain; charset=utf-8",
                )
                return
            if parts.path == "/":
                page = _page().replace("__TOKEN__", server.token)
                self._send(HTTPStatus.OK, page.encode(), "text/html; charset=utf-8")
            elif parts.path == "/status.json":
                body = json.dumps(live_status(server.feed, server.shown)).encode()
                self._send(HTTPStatus.OK, body, "application/json")
            elif parts.path.startswith("/frame/") and parts.path.endswith(".png"):
                self._frame(parts.path[len("/frame/") : -len(".png")], query)
            else:
                self._send(HTTPStatus.NOT_FOUND, b"no such page\n", "text/plain")

        def _frame(self, camera: str, query: dict[str, list[str]]) -> None:
            if camera not in server.shown:
                self._send(HTTPStatus.NOT_FOUND, b"no such camera\n", "text/plain")
                return
            shown = server.shown[camera]
            _page_report(shown, query)
            after = int(query.get("after", ["-1"])[0])
            frame = server.feed.latest[camera].wait_newer(after, timeout=1.0)
            if frame is None:
                self._send(HTTPStatus.NO_CONTENT, b"", "text/plain")
                return
            png, figures = shown.encode(frame)
            headers = {
                "X-Seq": str(frame.seq),
                "X-Captured-At": f"{frame.captured_at:.6f}",
                "X-Saturated": repr(figures["saturated"]),
                "X-Zero": repr(figures["zero"]),
            }
            self._send(HTTPStatus.OK, png, "image/png", headers)

        def _send(
            self, status: int, body: bytes, kind: str, headers: dict[str, str] | None = None
        ) -> None:
            with contextlib.suppress(BrokenPipeError, ConnectionResetError):
                self.send_response(status)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(body)))
                self.send_header("Cache-Control", "no-store")
                for key, value in (headers or {}).items():
                    self.send_header(key, value)
                self.end_headers()
                self.wfile.write(body)

    return Handler


def _page_report(shown: _Shown, query: dict[str, list[str]]) -> None:
    """Take in what the page measured of the frame it showed last (latency, rate)."""
    with contextlib.suppress(KeyError, IndexError, ValueError), shown.lock:
        latency = float(query["latency"][0])
        if 0 <= latency < 60:  # a page's clock cannot make the figures nonsense (NaN fails)
            _keep_last(shown.display_latency_s, latency)
        fps = float(query["fps"][0])
        if 0 <= fps < 1000:
            shown.display_fps = fps


@contextlib.contextmanager
def serving(
    rig: Rig,
    *,
    port: int = 0,
    lights: Sequence[str] | None = None,
    data: str | os.PathLike[str] | None = None,
    max_fps: float = 10.0,
    live_exposure_s: float | None = None,
) -> Iterator[LiveServer]:
    """The rig's lock held, its live feed running and served; all stopped on leaving.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        with serving(open_rig("sim"), lights=["laser:532"]) as server:
            print(server.url)
    """
    with driving(rig, data, "live"):
        feed = alignment_feed(rig, lights, max_fps=max_fps, live_exposure_s=live_exposure_s)
        server = LiveServer(feed, port=port)
        try:
            feed.start()
            server.start()
            yield server
        finally:
            server.stop()
            feed.stop()


def serve_live(
    rig: Rig,
    *,
    port: int = 0,
    lights: Sequence[str] | None = None,
    data: str | os.PathLike[str] | None = None,
    max_fps: float = 10.0,
    live_exposure_s: float | None = None,
    on_ready: Callable[[LiveServer], None] | None = None,
) -> None:
    """Serve ``rig``'s live view until Ctrl-C, SIGTERM or an error in the captures.

    Parameters
    ----------
    rig
        The rig (closed by the caller).
    port
        The port (0: a free one).
    lights
        The reading lights (see :func:`alignment_feed`).
    data
        The data root (for the rig's lock).
    max_fps
        The most live frames a second.
    live_exposure_s
        The live frames' exposure (s); ``None``: auto-exposure's.
    on_ready
        Called with the server once it serves (prints the address).

    Raises
    ------
    Exception
        What stopped the captures, when something did.
    """
    with serving(
        rig,
        port=port,
        lights=lights,
        data=data,
        max_fps=max_fps,
        live_exposure_s=live_exposure_s,
    ) as server:
        if on_ready is not None:
            on_ready(server)
        while server.feed.running:
            time.sleep(0.2)
        if server.feed.error is not None:
            raise server.feed.error
