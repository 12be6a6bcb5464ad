"""Live frames of a rig's cameras: a capture thread fills a one-slot buffer per camera.

A live view must never slow the captures down: :class:`LiveFeed` captures the spectral
and guide cameras on its own thread, each frame replacing the last in a
:class:`LatestFrame` slot, and whatever shows them (a browser page, a notebook widget)
takes the newest frame when it is ready for one. Frames nobody took are dropped, and
counted. Every few seconds the thread also captures one spectral frame under each of the
reading lights (a readings round) and hands them to a second thread, which computes the
readings the caller asked for (the alignment readings, in practice): a slow reading
never holds the frames up. Nothing is stored: stopping the feed loses nothing.

Examples
--------
Not run here (it needs a bench, captured sessions or files)::

    from sassi_bench import open_rig
    with LiveFeed(open_rig("sim"), lights=["laser:532"], pattern=pinholes) as feed:
        frame = feed.latest["spectral"].wait_newer(-1, timeout=60)
    frame.data.shape
    # (512, 800)
"""

from __future__ import annotations

import collections
import functools
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from numpy.typing import NDArray

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.trigger_gate import armed
from sassi_bench.rig import Rig

__all__ = ["CAMERAS", "LatestFrame", "LiveFeed", "LiveFrame", "RateMeter"]

#: The cameras a live feed captures, in the order it captures them.
CAMERAS = ("spectral", "guide")


@dataclass(frozen=True)
class LiveFrame:
    """One live frame.

    Attributes
    ----------
    camera
        ``"spectral"`` or ``"guide"``.
    seq
        The frame's number on its camera, from 0, with no gaps: a gap between two frames
        a viewer took is the frames it dropped.
    data
        The pixel values, as the camera gave them.
    bit_depth
        The camera's bits per value.
    captured_at
        Wall-clock time (``time.time()``) the capture returned: a browser on the same
        machine measures its latency from it.
    light
        The light the frame was taken under.
    """

    camera: str
    seq: int
    data: NDArray[Any]
    bit_depth: int
    captured_at: float
    light: str


class LatestFrame:
    """A one-slot buffer: the newest frame of one camera.

    ``put`` replaces the frame (never waits); ``wait_newer`` returns the newest frame
    once it is newer than the one a reader has. ``dropped`` counts the frames replaced
    before anyone took them.

    Examples
    --------
    >>> slot = LatestFrame()
    >>> slot.put(LiveFrame("spectral", 0, np.zeros((2, 2)), 12, 0.0, "led"))
    >>> slot.wait_newer(-1, timeout=0).seq
    0
    >>> slot.wait_newer(0, timeout=0) is None
    True
    """

    def __init__(self) -> None:
        self._frame: LiveFrame | None = None
        self._taken = True
        self._changed = threading.Condition()
        self.dropped = 0

    def put(self, frame: LiveFrame) -> None:
        """Replace the frame with ``frame`` and wake the readers."""
        with self._changed:
            if not self._taken:
                self.dropped += 1
            self._frame, self._taken = frame, False
            self._changed.notify_all()

    def peek(self) -> LiveFrame | None:
        """The newest frame, or ``None`` before the first (not counted as taken)."""
        with self._changed:
            return self._frame

    def wait_newer(self, seq: int, timeout: float | None = None) -> LiveFrame | None:
        """The newest frame once its number is above ``seq``; ``None`` after ``timeout``
        seconds without one."""
        with self._changed:
            newer = self._changed.wait_for(
                lambda: self._frame is not None and self._frame.seq > seq, timeout
            )
            if not newer:
                return None
            self._taken = True
            return self._frame


class RateMeter:
    """Events per second over the last ``window_s`` seconds.

    Examples
    --------
    >>> meter = RateMeter()
    >>> for t in (0.0, 0.1, 0.2, 0.3):
    ...     meter.tick(t)
    >>> round(meter.rate(0.3), 1)
    10.0
    """

    def __init__(self, window_s: float = 3.0) -> None:
        self.window_s = window_s
        self._times: collections.deque[float] = collections.deque()
        self._lock = threading.Lock()

    def tick(self, now: float | None = None) -> None:
        """Count one event (at ``now``, default the monotonic clock)."""
        with self._lock:
            self._times.append(time.monotonic() if now is None else now)

    def rate(self, now: float | None = None) -> float:
        """Events per second in the window ending at ``now``."""
        now = time.monotonic() if now is None else now
        with self._lock:
            while self._times and self._times[0] < now - self.window_s:
                self._times.popleft()
            if len(self._times) < 2:
                return 0.0
            span = max(self._times[-1] - self._times[0], 1e-9)
            return (len(self._times) - 1) / span


@dataclass(frozen=True)
class Readings:
    """The readings of one round, when they were ready and how long they took."""

    values: list[Any]
    ready_at: float
    processing_s: float
    round_index: int


class LiveFeed:
    """Capture a rig's cameras continuously on a thread; readings every few seconds.

    Parameters
    ----------
    rig
        The rig (its lock is the caller's to hold).
    lights
        The reading lights (each readings round takes one spectral frame under each);
        the live frames are taken under ``live_light``, default the first of them.
    pattern
        The SLM pattern shown for the whole feed (a pattern descriptor).
    analyse
        Computes the readings from a round's frames (``{light: frame}``); ``None``: no
        readings.
    live_light
        The light of the live frames (default ``lights[0]``).
    readings_every_s
        Seconds between readings rounds (a round starts only once the last one is read).
    max_fps
        The most live frames a second (the captures leave the rest of the machine alone).
    max_exposure_s
        The longest exposure auto-exposure may choose.
    live_exposure_s
        The exposure of the live frames (s); ``None``: auto-exposure's (the readings
        rounds always auto-expose).
    scene
        The scene in front of the cameras.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        feed = LiveFeed(rig, lights=["laser:532"], pattern=pinholes).start()
        frame = feed.latest["spectral"].wait_newer(-1, timeout=30)
        feed.stop()
    """

    def __init__(
        self,
        rig: Rig,
        *,
        lights: Sequence[str],
        pattern: Mapping[str, Any],
        analyse: Callable[[dict[str, NDArray[Any]]], list[Any]] | None = None,
        live_light: str | None = None,
        readings_every_s: float = 3.0,
        max_fps: float = 10.0,
        max_exposure_s: float = 2.0,
        live_exposure_s: float | None = None,
        scene: str = "white",
    ) -> None:
        if not lights:
            raise ValueError("live view: no reading lights; name at least one light")
        self.rig = rig
        self.lights = list(lights)
        self.live_light = live_light or self.lights[0]
        self.pattern = dict(pattern)
        self.analyse = analyse
        self.readings_every_s = readings_every_s
        self.max_fps = max_fps
        self.max_exposure_s = max_exposure_s
        self.live_exposure_s = live_exposure_s
        self.scene = scene
        self.latest = {camera: LatestFrame() for camera in CAMERAS}
        self.captured = {camera: RateMeter() for camera in CAMERAS}
        self.readings: Readings | None = None
        self.status = "not started"
        self.error: BaseException | None = None
        self._stop = threading.Event()
        self._round: tuple[int, dict[str, NDArray[Any]]] | None = None
        self._round_ready = threading.Condition()
        self._threads: list[threading.Thread] = []

    # --- running -------------------------------------------------------------------
    def start(self) -> LiveFeed:
        """Start the capture and readings threads; returns the feed."""
        if self._threads:
            return self
        self.status = "starting"
        self._threads = [
            threading.Thread(target=self._capture_loop, name="live-capture", daemon=True),
            threading.Thread(target=self._readings_loop, name="live-readings", daemon=True),
        ]
        for thread in self._threads:
            thread.start()
        return self

    def stop(self, timeout: float = 30.0) -> None:
        """Stop capturing: the capture in progress finishes, the trigger is left as it was
        found, and both threads are joined."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout)
        if self.error is None:
            self.status = "stopped"

    @property
    def running(self) -> bool:
        """Whether the capture thread is still capturing."""
        return bool(self._threads) and self._threads[0].is_alive()

    def __enter__(self) -> LiveFeed:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # --- the threads -----------------------------------------------------------------
    def _capture_loop(self) -> None:
        try:
            self._capture()
        except BaseException as exc:  # shown by the viewer, not lost in a thread
            self.error = exc
            self.status = f"stopped by an error: {exc}"
            self._stop.set()

    def _capture(self) -> None:
        rig = self.rig
        rig.set_scene(self.scene)
        exposures: dict[str, float] = {}

        def exposure(light: str) -> float:
            """Auto-exposure's for ``light``, found the first time it is needed (the
            live frames start before the readings' lights are exposed for)."""
            if light not in exposures:
                self.status = f"finding the exposure under {light}"
                exposures[light] = auto_exposure(
                    rig, light, self.pattern, max_s=self.max_exposure_s, target_fraction=0.6
                )
                self.status = "live"
            return exposures[light]

        cameras = {"spectral": rig.spectral_camera, "guide": rig.guide_camera}
        seqs = dict.fromkeys(CAMERAS, 0)
        period = 1.0 / self.max_fps
        next_round = time.monotonic()
        round_index = 0
        shown = render_pattern(self.pattern, rig.slm.shape)
        with armed(rig):
            live_exposure = self.live_exposure_s or exposure(self.live_light)
            rig.slm.show(shown)
            self.status = "live"
            while not self._stop.is_set():
                start = time.monotonic()
                rig.light.select(self.live_light)
                rig.spectral_camera.set_exposure(live_exposure)
                for name, camera in cameras.items():
                    data = camera.capture().data
                    frame = LiveFrame(
                        name, seqs[name], data, camera.bit_depth, time.time(), self.live_light
                    )
                    self.latest[name].put(frame)
                    self.captured[name].tick()
                    seqs[name] += 1
                if self.analyse is not None and start >= next_round and self._round_read():
                    frames = {}
                    for light in self.lights:
                        if self._stop.is_set():
                            return
                        chosen = exposure(light)
                        rig.slm.show(shown)  # auto-exposure shows its own frames
                        rig.light.select(light)
                        rig.spectral_camera.set_exposure(chosen)
                        frames[light] = rig.spectral_camera.capture().data
                    with self._round_ready:
                        self._round = (round_index, frames)
                        self._round_ready.notify_all()
                    round_index += 1
                    next_round = time.monotonic() + self.readings_every_s
                self._stop.wait(max(0.0, period - (time.monotonic() - start)))

    def _round_read(self) -> bool:
        """Whether the last round's readings are in (a round waits for them)."""
        with self._round_ready:
            last = self._round
        return last is None or (self.readings is not None and self.readings.round_index >= last[0])

    def _round_after(self, seq: int) -> bool:
        return self._round is not None and self._round[0] > seq

    def _readings_loop(self) -> None:
        seq = -1
        while not self._stop.is_set():
            with self._round_ready:
                fresh = self._round_ready.wait_for(
                    functools.partial(self._round_after, seq), timeout=0.2
                )
                taken = self._round if fresh else None
            if taken is None or self.analyse is None:
                continue
            seq, frames = taken
            start = time.monotonic()
            try:
                values = self.analyse(frames)
            except Exception as exc:  # a reading that fails is said; the frames go on
                values = [f"the readings failed: {exc}"]
            self.readings = Readings(values, time.time(), time.monotonic() - start, seq)
