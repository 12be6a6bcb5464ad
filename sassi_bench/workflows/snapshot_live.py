"""Live SASSI snapshots: capture and reconstruction overlapped, frames into a video store.

:func:`run_live` runs two threads:

* **capture** shows the latest planned mask on the SLM, takes the guide and spectral
  frames (moving the scene first on the virtual bench with ``moving``) and puts them on a
  bounded queue. When the queue is full the frame is dropped and counted: the capture
  never waits for the reconstruction (back-pressure), and frames are never reordered;
* **reconstruction** (the calling thread) takes frames in capture order, runs the
  per-frame pipeline (:class:`~sassi_bench.snapshot.video.VideoPipeline`: spectra beside
  the segmentation), hands the mask it plans to the capture, and appends the rank-1 frame
  in factored form to the Zarr store (:class:`~sassi_bench.snapshot.video_store.VideoStore`).

The progress line shows the frames stored per second, the drops, and the two rates apart:
capturing a frame (on the virtual bench: rendering it, the bench's cost) and processing it
(the pipeline's). Ctrl-C stops the capture, reconstructs and stores every frame already
captured, writes the quick-look animation, and re-raises; every stored frame stays
readable (:func:`~sassi_bench.snapshot.video_store.read_frame`).

Live masks are planned by :func:`~sassi_bench.snapshot.adaptive.place_samples` (samples at
the superpixels' centroids, then every further pixel in row order): the residual-first fill
of ``snapshot take`` needs a second segmentation a frame.
"""

from __future__ import annotations

import os
import queue
import statistics
import threading
import time
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench._shared.signals import deferred_stop_signals
from sassi_bench.acquire.snapshots import snapshot_exposures
from sassi_bench.acquire.trigger_gate import armed
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.snapshots import procedure_spacing
from sassi_bench.rig.rig import Rig
from sassi_bench.rig.scene_pose import ScenePose
from sassi_bench.snapshot.video import VideoPipeline
from sassi_bench.snapshot.video_store import VideoStore
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.snapshot import check_inputs

__all__ = ["LiveRun", "run_live"]

STEP = "snapshot live"


@dataclass
class LiveRun:
    """What a live run did.

    Attributes
    ----------
    store, animation
        The video store and the quick-look animation (None when no frame was stored).
    captured, stored, dropped
        Frames captured, reconstructed and stored, and dropped because the reconstruction
        was behind.
    capture_s, process_s
        Median seconds to capture a frame (virtual bench: to render it) and to reconstruct it.
    elapsed_s
        Wall-clock seconds of the run.
    interrupted
        True when Ctrl-C stopped it.
    """

    store: Path
    animation: Path | None
    captured: int
    stored: int
    dropped: int
    capture_s: float
    process_s: float
    elapsed_s: float
    interrupted: bool = False


@dataclass(frozen=True)
class _Captured:
    index: int
    time_s: float
    guide: np.ndarray
    spectral: np.ndarray
    mask: np.ndarray
    samples: np.ndarray


class _Capture(threading.Thread):
    """The capture thread: frames onto a bounded queue, drops counted when it is full; the
    trigger armed while it captures (a camera on a line trigger waits for its pulses)."""

    def __init__(self, rig, scene, motion, plan, frames, seconds, size):
        super().__init__(name="snapshot-capture", daemon=True)
        self.rig, self.scene, self.motion = rig, scene, motion
        self.frames, self.seconds = frames, seconds
        self.queue: queue.Queue[_Captured] = queue.Queue(maxsize=size)
        self.stop = threading.Event()
        self.lock = threading.Lock()
        self.plan = plan  # (mask, samples) to show next, replaced by the reconstruction
        self.captured = 0
        self.dropped = 0
        self.capture_s: list[float] = []
        self.error: BaseException | None = None
        self.start_time = time.perf_counter()

    def set_plan(self, mask: np.ndarray, samples: np.ndarray) -> None:
        with self.lock:
            self.plan = (mask, samples)

    def _done(self) -> bool:
        if self.stop.is_set() or (self.frames is not None and self.captured >= self.frames):
            return True
        return self.seconds is not None and time.perf_counter() - self.start_time >= self.seconds

    def run(self) -> None:
        try:
            with armed(self.rig):
                self._capture()
        except BaseException as exc:  # handed to the reconstruction thread, which re-raises
            self.error = exc

    def _capture(self) -> None:
        while not self._done():
            start = time.perf_counter()
            if self.motion is not None:
                pose = ScenePose.at_frame(self.captured, *self.motion)
                self.rig.set_scene(self.scene, pose)
            with self.lock:
                mask, samples = self.plan
            self.rig.slm.show(mask)
            guide = self.rig.guide_camera.capture().data
            spectral = self.rig.spectral_camera.capture().data
            stamp = time.perf_counter()
            self.capture_s.append(stamp - start)
            item = _Captured(self.captured, stamp - self.start_time, guide, spectral, mask, samples)
            self.captured += 1
            try:
                self.queue.put_nowait(item)
            except queue.Full:
                self.dropped += 1


def _compile_kernels(rig, bundle, spacing, snap, guide, plan, exposures, progress) -> None:
    """Reconstruct one frame, not stored, with a pipeline of its own before the clock
    starts: the kernels compile at their first call (seconds), and frames captured
    meanwhile would fill the queue and be dropped. The live pipeline starts fresh."""
    from tqdm.auto import tqdm

    if progress:
        tqdm.write(f"{STEP}: preparing the reconstruction (one frame, not stored)")
    with VideoPipeline(bundle, spacing, compactness=float(snap["compactness"])) as warm:
        for _ in range(2):  # the first frame's path, then the one frames after it take
            rig.slm.show(plan[0])
            spectral = rig.spectral_camera.capture().data
            frame = warm.process(guide, spectral, *plan, exposure_s=exposures.spectral_s)
            plan = (frame.next_mask, frame.next_samples)


@drives_rig("snapshot live")
def run_live(
    rig: Rig,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    scene: str,
    out: str | os.PathLike[str],
    frames: int | None = None,
    seconds: float | None = None,
    moving: bool = False,
    queue_size: int = 2,
    band_nm: float = 550.0,
    progress: bool = True,
) -> LiveRun:
    """Capture and reconstruct snapshots live until ``frames`` or ``seconds`` (or Ctrl-C).

    Parameters
    ----------
    rig, bundle
        Device handles and the bundle (it needs a guide homography and the rig's SLM).
    procedure
        ``load_procedure("snapshot_validation")``: its ``snapshot`` (light, row pitch,
        compactness) and ``video`` (motion) sections.
    scene
        What is in front of the bench.
    out
        A new folder: ``video.zarr`` and ``quicklook.gif`` are written there.
    frames, seconds
        Stop after this many captured frames, or this many seconds (one of them, or both).
    moving
        Move the scene by the procedure's ``video`` motion each frame (virtual bench).
    queue_size
        Captured frames that may wait for the reconstruction; more are dropped.
    band_nm
        The band shown beside the RGB rendering in the animation.
    progress
        Progress line (frames per second, drops, capture and processing times).

    Returns
    -------
    LiveRun

    Raises
    ------
    KeyboardInterrupt
        After every captured frame is stored and the animation written.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        run = run_live(open_rig("sim"), load(rig="sim"), load_procedure("snapshot_validation"),
                       scene="natural", out="live", frames=10, moving=True)
        run.stored + run.dropped == run.captured
        # True
    """
    from tqdm.auto import tqdm

    from sassi_bench.plots.snapshot_video import video_animation

    check_inputs(rig, bundle, scene, step=STEP)
    if frames is None and seconds is None:
        raise ProcedureError(step_error(STEP, "no end given", "pass --frames N or --seconds S"))
    if (frames is not None and frames < 1) or (seconds is not None and not seconds > 0):
        raise ProcedureError(
            step_error(STEP, f"frames {frames}, seconds {seconds}", "ask for 1 frame or more")
        )
    if not (isinstance(queue_size, int) and queue_size >= 1):
        raise ProcedureError(step_error(STEP, f"queue size {queue_size!r}", "pass 1 or more"))
    folder = Path(out)
    store_path = folder / "video.zarr"
    if store_path.exists():
        raise ProcedureError(
            step_error(STEP, f"{store_path} exists", "write into a new --out folder")
        )
    spacing = procedure_spacing(bundle, procedure)
    snap = procedure["snapshot"]
    motion = None
    if moving:
        cfg = procedure["video"]
        motion = (tuple(cfg["shift_px_per_frame"]), float(cfg["rotation_deg_per_frame"]))
    rig.set_scene(scene, None)
    pattern = {"kind": "pinholes", "pitch": [spacing.uniform_step, spacing.pitch]}
    exposures = snapshot_exposures(rig, snap["light"], pattern)
    rig.light.select(snap["light"])
    rig.spectral_camera.set_exposure(exposures.spectral_s)
    rig.guide_camera.set_exposure(exposures.guide_s)
    pipeline = VideoPipeline(bundle, spacing, compactness=float(snap["compactness"]))
    with armed(rig):
        guide = rig.guide_camera.capture().data
        first_plan = pipeline.plan(guide)
        _compile_kernels(rig, bundle, spacing, snap, guide, first_plan, exposures, progress)
    folder.mkdir(parents=True, exist_ok=True)
    started = datetime.now(UTC).isoformat(timespec="milliseconds")
    store: VideoStore | None = None
    capture = _Capture(rig, scene, motion, first_plan, frames, seconds, queue_size)
    process_s: list[float] = []
    interrupted = False
    bar = tqdm(total=frames, desc=STEP, unit="frame", disable=not progress)

    def reconstruct(item: _Captured) -> None:
        nonlocal store
        if store is not None and store.frames and store.last_index == item.index:
            return  # stored already; Ctrl-C came before it was marked done
        frame = pipeline.process(
            item.guide, item.spectral, item.mask, item.samples, exposure_s=exposures.spectral_s
        )
        capture.set_plan(frame.next_mask, frame.next_samples)
        # A Ctrl-C lands after the frame is stored, not half-way into the store (it used to
        # leave a store without its frame, or no store at all at the first frame).
        with deferred_stop_signals():
            if store is None:
                store = VideoStore(
                    store_path, bundle, units=frame.units,
                    attrs={"started": started, "rig": rig.description.name, "scene": scene,
                           "moving": bool(moving), "exposures": exposures.to_dict(),
                           "row_pitch_px": int(spacing.pitch), "queue_size": queue_size},
                )  # fmt: skip
            store.append(frame.rank1, item.mask, time_s=item.time_s, frame_index=item.index)
        process_s.append(frame.seconds["total"])
        elapsed = time.perf_counter() - capture.start_time
        bar.update(1)
        bar.set_postfix_str(
            f"{store.frames / elapsed:.1f} fps stored, {capture.dropped} dropped, capture "
            f"{1e3 * statistics.median(capture.capture_s):.0f} ms, process "
            f"{1e3 * statistics.median(process_s):.0f} ms"
        )

    pending: _Captured | None = None
    capture.start()
    try:
        while capture.is_alive() or not capture.queue.empty():
            try:
                pending = capture.queue.get(timeout=0.05)
            except queue.Empty:
                continue
            reconstruct(pending)
            pending = None
    except KeyboardInterrupt:
        interrupted = True
        capture.stop.set()
        capture.join()
        # Every frame captured so far is kept: the one being reconstructed, then the queue.
        if pending is not None:
            reconstruct(pending)
        while not capture.queue.empty():
            reconstruct(capture.queue.get())
    finally:
        capture.stop.set()
        capture.join()
        pipeline.close()
        bar.close()
    if capture.error is not None:
        raise capture.error
    elapsed = time.perf_counter() - capture.start_time
    run = LiveRun(
        store=store_path,
        animation=None,
        captured=capture.captured,
        stored=store.frames if store is not None else 0,
        dropped=capture.dropped,
        capture_s=statistics.median(capture.capture_s) if capture.capture_s else float("nan"),
        process_s=statistics.median(process_s) if process_s else float("nan"),
        elapsed_s=elapsed,
        interrupted=interrupted,
    )
    if store is not None:
        store.update(
            captured=run.captured, dropped=run.dropped, elapsed_s=elapsed,
            capture_s_median=run.capture_s, process_s_median=run.process_s,
            stopped="interrupted" if interrupted else "complete",
        )  # fmt: skip
        run.animation = video_animation(store_path, folder / "quicklook.gif", band_nm=band_nm)
    if interrupted:
        raise KeyboardInterrupt
    return run
