"""Nyquist pinhole scans (reference cubes): the plan, and streaming assembly into a cube.

A Nyquist pinhole scan opens SLM pixels on a grid (100 px apart horizontally, 5 px
vertically by default) and shifts it through every offset, so every SLM pixel is open
in exactly one of the 100 x 5 = 500 frames. Assembly reads every frame from the session
once, a few frames in memory at a time (threads work on several frames at once):

1. **Reading pass.** Every frame carries the same smooth background (closed pixels leak
   ``1/contrast`` of the light; plus the dark level). A camera pixel outside the
   predicted streak footprints of a frame sees only that background, and across the
   shifted frames every camera pixel is free in dozens of frames, so the background is
   averaged per pixel over those frames. The full scan needs no closed-SLM frame (one,
   when the plan has it, checks the estimate); a scan of a few offsets (the response's)
   leaves pixels that are never free, and those take the closed frame's value plus a
   smooth correction (:func:`_mean_background`). The same pass keeps each open pixel's raw
   cell sums (:mod:`~sassi_bench.spectra.cells`), which are linear in the frame, in the
   cube's own memory, and flags streaks that are saturated or leave the camera.
2. **Spectra pass.** With the background known, its cell sums are subtracted and the
   stacked pixels unmixed (:mod:`~sassi_bench.spectra.extract`), in place; the noise
   variance of every pixel's column sums is kept beside them
   (:class:`~sassi_bench.spectra.noise.CountsNoise`, from the rig's camera). Frames with
   NaNs or the wrong shape, and streaks that are saturated or leave the camera, are
   reported by frame and SLM pixel and flagged in a quality mask instead of being filled
   in.
3. **Deblur** (:mod:`~sassi_bench.spectra.scan_deblur`). The regularisation is chosen
   once per session, from every pixel of a seeded choice of its frames, extracted whole
   whatever the ROI: their mean spectrum, deblurred once at its own noise, is the
   reference of the per-pixel prior (the curvature of each spectrum relative to it), and
   the strength is chosen from them and their noise
   (:meth:`~sassi_bench.spectra.deblur.SpectralDeblur.choose`). An ROI's cube is so the
   whole scan's there. The choice, and the per-band noise of the deblurred cube, go with
   the cube.

Only the camera rows that light of the SLM can reach are processed; the background is
NaN on the others.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from threadpoolctl import threadpool_limits

from sassi_bench._shared.threads import run_in_order
from sassi_bench.acquire.patterns import open_pixels
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.scan_plans import Roi, check_roi
from sassi_bench.acquire.streak_pitch import FOOTPRINT_MARGIN_PX, FOOTPRINT_SIGMAS
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra import _kernels
from sassi_bench.spectra.cells import cell_layout, cell_sums, column_cumsum
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.geometry import GUARD_BINS, StreakGeometry, reached_rows, streak_geometry
from sassi_bench.spectra.noise import CountsNoise, row_unmixing_gain
from sassi_bench.spectra.offset import estimate_background, footprint_rectangles
from sassi_bench.spectra.regularisation import RegularisationChoice
from sassi_bench.spectra.scan_deblur import (
    ChoiceSample,
    ScanDeblur,
    deblur_scan,
    sample_frames,
    stack_bins,
)
from sassi_bench.spectra.unmixing import row_unmixing

__all__ = [
    "QUALITY_FLAGS",
    "ScanAssembly",
    "ScanCube",
]

#: Bits of the quality mask.
QUALITY_FLAGS = {"not_measured": 1, "off_camera": 2, "saturated": 4, "bad_frame": 8}

#: SLM rows beyond an ROI that are extracted too, so that the ROI's edge pixels are
#: unmixed from their stacked neighbours: the row unmixing's inverse decays by a factor
#: of about 2.3 per neighbour at the blurriest bins (sigma 3.4 px, 5 px pitch), so twenty
#: neighbours (100 rows) leave less than 1e-6 of the light.
ROI_MARGIN_ROWS = 100


#: How far a pinhole's streak footprint, which its frame's background samples avoid,
#: reaches beyond the band's end bins: blur sigmas and camera px
#: (:func:`~sassi_bench.spectra.offset.footprint_rectangles`); the plan-time pitch check
#: reserves the same (:mod:`~sassi_bench.acquire.streak_pitch`). Under the blue end of a
#: streak the background is many times the pinhole's own light, so samples still holding
#: 1e-3 of another streak's red end bias those bins by several per cent; this reach keeps
#: them out (``docs/notes/2026-12-01-measured-in-code-comments.md``).
FOOTPRINT_REACH = (FOOTPRINT_SIGMAS, FOOTPRINT_MARGIN_PX)


@dataclass
class ScanCube:
    """An assembled scan: signal per second per bin on the SLM grid, and its quality.

    Attributes
    ----------
    cube
        (H, W, B) float32, camera units per second (divide by a response for radiance).
    quality
        (H, W) uint8 bit mask (:data:`QUALITY_FLAGS`); 0 = good.
    wavelengths_nm, bin_edges_nm
        The bundle's bins.
    origin
        (row, column) of the cube's first pixel on the SLM (an ROI's corner).
    background
        The background estimate (H_cam, W_cam) in camera units; NaN on camera rows that
        no streak reaches.
    background_check_rms
        RMS difference between the estimate and the closed-SLM frame, if one was taken.
    problems
        One line per frame or pixel problem (frame index, SLM pixel, cause).
    deblur
        How the deblur's regularisation was chosen (None: not deblurred).
    mean_spectrum
        (B',) the scan's mean light per bin and second, guard bins included, deblurred
        at its own noise (the per-pixel prior's reference); None when not deblurred.
    band_noise_psnr_db
        (B,) per-band PSNR of the cube against its own noise: the cube's peak over the
        RMS of the deblurred spectra's noise alone (propagated from the photon and read
        noise, no reference cube); None when not deblurred.
    column_sums
        (H, W, B') the unmixed column sums per second before the deblur, guard bins
        included, when kept (``keep_raw``): means of them are deblurred once, at the
        mean's noise (:class:`~sassi_bench.spectra.deblur.MeanDeblur`).
    noise_variance
        (H, W) each pixel's column-sum noise variance per second squared (mean over the
        bins), when kept.
    """

    cube: NDArray[np.float32]
    quality: NDArray[np.uint8]
    wavelengths_nm: NDArray[np.float64]
    bin_edges_nm: NDArray[np.float64]
    origin: tuple[int, int]
    background: NDArray[np.float64]
    background_check_rms: float | None
    mean_streak_signal: float
    problems: list[str] = field(default_factory=list)
    deblur: RegularisationChoice | None = None
    mean_spectrum: NDArray[np.float64] | None = None
    band_noise_psnr_db: NDArray[np.float64] | None = None
    column_sums: NDArray[np.float32] | None = None
    noise_variance: NDArray[np.float32] | None = None


class _Scratch:
    """One thread's share of the reading pass: its background sums (free pixels' total and
    count over the frames it read) and a frame's working buffers, reused from frame to
    frame."""

    def __init__(self, box: tuple[int, int]):
        self.total = np.zeros(box)
        self.count = np.zeros(box, dtype=np.int32)
        self.cumulative = np.empty((box[0] + 1, box[1]))
        self.marks = np.zeros((box[0], box[1] + 1), dtype=np.int32)


@dataclass
class _Frame:
    """What the reading pass keeps of a frame for the spectra pass."""

    index: int
    rows: NDArray[np.intp]  # SLM pixels extracted (the work area's)
    cols: NDArray[np.intp]
    problems: list[str]
    usable: bool


class ScanAssembly:
    """A pinhole scan being assembled: its frames taken one at a time, in any order, on any
    thread (the reading pass), then the cube made from them (:meth:`finish`).

    The work area covers the ROI's columns, and rows beyond it so that the ROI's edge
    pixels are unmixed from their neighbours outside it too. Frames write disjoint SLM
    pixels (each is open in one frame), so threads fill it without locking; each thread
    keeps its own background sums, added up once all frames are read. Every sum of the
    reading pass is exact (integer frames summed in float64), so the cube does not depend
    on the order the frames came in or on how they were shared among threads: frames
    taken while the session fills (:class:`~sassi_bench.acquire.frame_feed.FrameFeed`)
    give the cube of the finished session, read back.

    Parameters
    ----------
    plan
        The plan of a pinhole scan (:func:`~sassi_bench.acquire.scan_plans.scan_plan`);
        frames it does not get leave their pixels flagged ``not_measured``.
    rig
        The description of the rig the frames come from, as a session stores it (its
        SLM's and spectral camera's sizes, the camera's bit depth and noise).
    bundle, roi, deblur, keep_raw, unmixing
        As for :func:`~sassi_bench.reduce.scan.assemble_scan`.

    Examples
    --------
    Not run here (it needs measured frames)::

        assembly = ScanAssembly(session.plan, session.rig, bundle)
        for index in assembly.steps:
            assembly.read(index, session.read_frame(index))
        scan = assembly.finish(progress=False)
    """

    def __init__(
        self,
        plan: Plan,
        rig: Mapping[str, Any],
        bundle: CalibrationBundle,
        *,
        roi: Sequence[int] | None = None,
        deblur: bool = True,
        keep_raw: bool = False,
        unmixing: str = "mixed",
    ):
        self.plan, self.bundle, self.keep_raw = plan, bundle, keep_raw
        self.slm_shape = (int(rig["slm"]["height"]), int(rig["slm"]["width"]))
        self.camera_shape = (
            int(rig["spectral_camera"]["height"]),
            int(rig["spectral_camera"]["width"]),
        )
        self.saturation = 2 ** int(rig["spectral_camera"]["bit_depth"]) - 1
        if tuple(bundle.slm_shape) != self.slm_shape:
            raise ProcedureError(
                step_error(
                    "scan assembly",
                    f"the bundle is for a {bundle.slm_shape} SLM, the session's rig has "
                    f"{self.slm_shape}",
                    "load the bundle of the rig the scan was taken on",
                )
            )
        self.pinholes = list(plan.select(role="pinholes"))
        closed = plan.select(role="closed")
        self.closed_step = closed[0] if closed else None
        self.closed_frame: NDArray | None = None
        model = StreakForwardModel.from_bundle(bundle)
        self.model = model if deblur else None
        self.unmix = row_unmixing(unmixing, model)
        self.noise = CountsNoise.from_camera(rig["spectral_camera"])
        self.roi = check_roi(roi, self.slm_shape)
        r0, c0, r1, c1 = self.roi
        h = self.slm_shape[0]
        self.w0, self.w1 = max(0, r0 - ROI_MARGIN_ROWS), min(h, r1 + ROI_MARGIN_ROWS)
        area = (self.w1 - self.w0, c1 - c0)
        self.n_bins = bundle.wavelengths.size
        self.work = np.zeros((*area, self.n_bins), dtype=np.float32)  # raw sums, then cube
        self.guards = np.zeros((*area, 2 * GUARD_BINS), dtype=np.float32)
        self.quality = np.full(area, QUALITY_FLAGS["not_measured"], dtype=np.uint8)
        self.exposure = np.zeros(area, dtype=np.float32)  # 0: not extracted
        self.variance = np.zeros(area, dtype=np.float32)
        # Only the camera rows that light of the SLM can reach are processed.
        self.top, bottom = reached_rows(bundle, self.camera_shape[0], guard=GUARD_BINS)
        self.box = (bottom - self.top, self.camera_shape[1])
        self.row_gain = self._row_gain()
        self.lock = threading.Lock()
        self.scratches: list[_Scratch] = []
        self.thread = threading.local()
        self.frames: list[_Frame] = []
        self.background_cumulative: NDArray[np.float64] | None = None
        # The frames whose every pixel chooses the deblur's regularisation, whatever the ROI
        # (scan_deblur.sample_frames), and their raw cell sums and good pixels.
        # Chosen among the plan's pinhole frames, not the ones stored yet: the frames come
        # while the session fills, and a partly captured session samples what it has.
        self.sample: frozenset[int] = frozenset()
        if deblur and self.pinholes:
            first = open_pixels(plan.steps[self.pinholes[0]].pattern, self.slm_shape)[0]
            self.sample = sample_frames(self.pinholes, first.size)
        self.sample_raw: dict[int, tuple[NDArray[np.float32], NDArray[np.bool_]]] = {}

    @property
    def steps(self) -> list[int]:
        """The plan steps the assembly reads: the pinhole frames and the first closed one."""
        return sorted(
            [*self.pinholes, *([self.closed_step] if self.closed_step is not None else [])]
        )

    def _row_gain(self) -> NDArray[np.float64]:
        """The row unmixing's noise gain: every frame stacks its pixels alike, so one gain
        for the scan, from the plan's first pinhole frame (the pattern alone)."""
        if not self.pinholes:
            return np.ones(self.n_bins + 2 * GUARD_BINS)
        rows, cols = open_pixels(self.plan.steps[self.pinholes[0]].pattern, self.slm_shape)
        geo = streak_geometry(self.bundle, rows, cols, GUARD_BINS).shifted(self.top)
        return row_unmixing_gain(geo, cell_layout(geo, self.box))

    def _scratch(self) -> _Scratch:
        """This thread's background sums and working buffers (made on first use)."""
        scratch = getattr(self.thread, "scratch", None)
        if scratch is None:
            scratch = self.thread.scratch = _Scratch(self.box)
            with self.lock:
                self.scratches.append(scratch)
        return scratch

    def _local(self, geo: StreakGeometry) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
        return geo.rows - self.w0, geo.cols - self.roi[1]

    def read(self, index: int, data: NDArray) -> None:
        """Reading pass of step ``index``'s frame: background samples, raw cell sums, their
        noise, and flags (the closed-SLM frame is kept to check the background)."""
        if index == self.closed_step:
            self.closed_frame = np.asarray(data)
            if self.closed_frame.shape != self.camera_shape:
                problem = (
                    f"frame {index} (closed SLM): shape {self.closed_frame.shape}, expected "
                    f"{self.camera_shape}; the background is estimated without it"
                )
                empty = np.zeros(0, dtype=np.intp)
                self.frames.append(_Frame(index, empty, empty, [problem], usable=False))
            return
        problems: list[str] = []
        data = np.asarray(data)
        rows, cols = open_pixels(self.plan.steps[index].pattern, self.slm_shape)
        _, c0, _, c1 = self.roi
        keep = (rows >= self.w0) & (rows < self.w1) & (cols >= c0) & (cols < c1)
        if data.shape != self.camera_shape:
            problems.append(
                f"frame {index}: shape {data.shape}, expected {self.camera_shape}; frame skipped"
            )
            self.quality[rows[keep] - self.w0, cols[keep] - c0] = QUALITY_FLAGS["bad_frame"]
            self.frames.append(_Frame(index, rows[keep], cols[keep], problems, usable=False))
            return
        window = data[self.top : self.top + self.box[0]]
        everything = streak_geometry(self.bundle, rows, cols, GUARD_BINS).shifted(self.top)
        scratch = self._scratch()
        # Per-thread sums: integer frames sum exactly, whatever the order of the frames.
        bad = _kernels.read_window(
            window,
            *footprint_rectangles(everything, self.box, *FOOTPRINT_REACH),
            self.saturation,
            scratch.cumulative,
            scratch.total,
            scratch.count,
            scratch.marks,
        )
        geo = everything if keep.all() else everything.select(keep)
        if index in self.sample and geo is not everything:  # an ROI: the whole frame too
            self._keep_sample(index, everything, scratch.cumulative, window, bad)
        if geo.rows.size == 0:
            self.frames.append(_Frame(index, geo.rows, geo.cols, problems, usable=True))
            return
        layout = cell_layout(geo, self.box)
        # The raw sums and their noise (light, background and dark level), in one pass.
        sums, variance = self.noise.cell_sums(scratch.cumulative, layout, self.row_gain)
        local = self._local(geo)
        self.work[local] = sums[:, geo.core]
        self.guards[local] = np.concatenate([sums[:, : geo.guard], sums[:, geo.core.stop :]], 1)
        self.variance[local] = variance.mean(axis=1)  # kept per pixel
        flags = np.where(layout.off[:, geo.core].any(axis=1), QUALITY_FLAGS["off_camera"], 0)
        if bad:
            flags = flags | _pixel_flags(window, geo, self.saturation, index, problems)
        self.quality[local] = flags
        if index in self.sample and geo is everything:
            self.sample_raw[index] = (sums, flags == 0)
        self.frames.append(_Frame(index, geo.rows, geo.cols, problems, usable=True))

    def _keep_sample(self, index: int, geo: StreakGeometry, cumulative, window, bad) -> None:
        """Raw cell sums and good pixels of every pixel of a sample frame (as read)."""
        layout = cell_layout(geo, self.box)
        flagged = layout.off[:, geo.core].any(axis=1)
        if bad:
            flagged |= _pixel_flags(window, geo, self.saturation, index, []) != 0
        self.sample_raw[index] = (cell_sums(cumulative, layout).astype(np.float32), ~flagged)

    def choice_sample(self) -> ChoiceSample:
        """The sample frames' pixels unmixed as the spectra pass does (after it)."""
        parts = []
        for index in sorted(self.sample_raw):  # a few dozen frames at most
            raw, good = self.sample_raw.pop(index)
            rows, cols = open_pixels(self.plan.steps[index].pattern, self.slm_shape)
            geo = streak_geometry(self.bundle, rows, cols, GUARD_BINS).shifted(self.top)
            layout = cell_layout(geo, self.box)
            variance = self.noise.variance(raw, layout, self.row_gain)
            covariance = self.noise.neighbour_covariance(raw, layout, self.row_gain)
            raw -= cell_sums(self.background_cumulative, layout)
            exposure = np.full(rows.size, self.plan.steps[index].exposure_s)
            amplitudes = self.unmix(raw, layout, geo)
            parts.append((amplitudes, rows, cols, variance, covariance, exposure, good))
        return ChoiceSample.of(parts, self.n_bins + 2 * GUARD_BINS)

    def _background(self, closed: NDArray | None) -> tuple[NDArray[np.float64], float | None]:
        """The background estimate on the whole camera (NaN where no light reaches), and
        its RMS difference from the ``closed`` SLM frame where the pinhole frames made it
        (None without a closed frame)."""
        background = np.full(self.camera_shape, np.nan)
        total, count = np.zeros(self.box), np.zeros(self.box, dtype=np.int64)
        for scratch in self.scratches:
            total += scratch.total
            count += scratch.count
        # The reading pass is over: free the threads' sums and buffers for the spectra pass.
        self.scratches.clear()
        self.thread = threading.local()
        rows = slice(self.top, self.top + self.box[0])
        # The closed frame fills only pixels that were never free (the full scan has none),
        # and only at the pinholes' exposure.
        steps = self.plan.steps
        fill = None
        if (
            closed is not None
            and not np.all(count)
            and {steps[index].exposure_s for index in self.pinholes}
            == {steps[self.closed_step].exposure_s}
        ):
            fill = np.asarray(closed[rows], dtype=np.float64)
        inside = _mean_background(total, count, fill)
        background[rows] = inside
        self.background_cumulative = column_cumsum(inside)
        check = None
        if closed is not None:
            # Only where the pinhole frames made the estimate: elsewhere it is that frame.
            residual = (closed[rows] - inside)[count > 0]
            check = float(np.sqrt(np.nanmean(residual**2))) if residual.size else None
        return background, check

    @property
    def missing_closed(self) -> int | None:
        """The plan's closed-SLM step if the reading pass has not had its frame (the
        caller may pass it to :meth:`read` before :meth:`finish`), else None."""
        if self.closed_step is None or self.closed_frame is not None:
            return None
        return self.closed_step

    def _closed(self) -> NDArray | None:
        """The closed-SLM frame, if the reading pass had one of the right shape."""
        if self.closed_frame is None or np.shape(self.closed_frame) != self.camera_shape:
            return None
        return self.closed_frame

    def _spectra(self, frame: _Frame) -> tuple[float, int]:
        """Spectra pass of one frame: subtract the background's cell sums and unmix."""
        if not frame.usable or frame.rows.size == 0:
            return 0.0, 0
        geo = streak_geometry(self.bundle, frame.rows, frame.cols, GUARD_BINS).shifted(self.top)
        layout = cell_layout(geo, self.box)
        local = self._local(geo)
        raw = stack_bins(self.work[local], self.guards[local], geo.guard)
        raw -= cell_sums(self.background_cumulative, layout)
        amplitudes = self.unmix(raw, layout, geo)
        self.work[local] = amplitudes[:, geo.core]
        self.guards[local] = np.concatenate(
            [amplitudes[:, : geo.guard], amplitudes[:, geo.core.stop :]], 1
        )
        exposure = self.plan.steps[frame.index].exposure_s
        self.exposure[local] = exposure
        signal = amplitudes[:, geo.core] / exposure
        good = self.quality[local] == 0
        return float(signal[good].sum(dtype=np.float64)), int(good.sum()) * self.n_bins

    def _deblur(self, run) -> tuple[ScanDeblur | None, NDArray | None]:
        """After the spectra pass: keep the column sums if asked, then deblur in place."""
        extracted = self.exposure > 0
        seconds = np.where(extracted, self.exposure, 1.0)[..., None]
        kept = None
        if self.keep_raw:
            # Row blocks (the float64 quotient of the whole area would be twice the cube),
            # and only the pixels extracted: the others stay 0 (a thinned scan's most).
            kept = np.zeros((*self.work.shape[:2], self.n_bins + 2 * GUARD_BINS), np.float32)
            for start in range(0, kept.shape[0], 64):
                rows = slice(start, start + 64)
                taken = extracted[rows]
                if taken.all():
                    stacked = stack_bins(self.work[rows], self.guards[rows], GUARD_BINS)
                    kept[rows] = stacked / seconds[rows]
                elif taken.any():
                    r, c = np.nonzero(taken)
                    r += start
                    stacked = stack_bins(self.work[r, c], self.guards[r, c], GUARD_BINS)
                    kept[r, c] = stacked / seconds[r, c]
        if self.model is None:
            self.work /= seconds
            return None, kept
        c0 = self.roi.col0
        result = deblur_scan(
            self.work, self.guards, self.exposure, self.choice_sample(), self.quality == 0,
            (self.w0, c0), self.model, float(self.saturation), run,
        )  # fmt: skip
        return result, kept

    def finish(self, *, progress: bool = True, workers: int | None = None) -> ScanCube:
        """The cube of every frame read: background, spectra pass, deblur.

        Parameters
        ----------
        progress
            Show progress bars.
        workers
            Threads for the spectra pass and the deblur (default: one per CPU).

        Returns
        -------
        ScanCube
        """
        workers = max(1, workers or os.cpu_count() or 1)
        closed = self._closed()
        frames = sorted(self.frames, key=lambda frame: frame.index)
        # One BLAS thread: the matrices are small (80 x 80 at the prototype scale), and
        # BLAS's spinning threads contend with ours or with any other load, many times
        # slower on a busy machine (``docs/notes/2026-12-01-measured-in-code-comments.md``).
        with threadpool_limits(limits=1, user_api="blas"):
            background, check = self._background(closed)
            signals = run_in_order(self._spectra, frames, "scan spectra", progress, workers)
            deblurred, kept = self._deblur(
                lambda task, items, label: run_in_order(
                    task, items, label, progress, workers, unit="block"
                ),
            )
        r0, c0, r1, _ = self.roi
        crop = slice(r0 - self.w0, r1 - self.w0)
        seconds = np.where(self.exposure > 0, self.exposure, 1.0) ** 2
        whole = self.roi == Roi(0, 0, *self.slm_shape)
        return ScanCube(
            cube=self.work if whole else self.work[crop].copy(),
            quality=self.quality if whole else self.quality[crop].copy(),
            wavelengths_nm=np.asarray(self.bundle.wavelengths),
            bin_edges_nm=np.asarray(self.bundle.bin_edges),
            origin=(r0, c0),
            background=background,
            background_check_rms=check,
            mean_streak_signal=sum(s for s, _ in signals) / max(sum(c for _, c in signals), 1),
            problems=[line for frame in frames for line in frame.problems],
            deblur=None if deblurred is None else deblurred.choice,
            mean_spectrum=None if deblurred is None else deblurred.mean_spectrum,
            band_noise_psnr_db=None if deblurred is None else deblurred.band_noise_psnr_db,
            column_sums=None if kept is None else kept[crop],
            noise_variance=(
                (self.variance / seconds)[crop].astype(np.float32) if self.keep_raw else None
            ),
        )


def _mean_background(
    total: NDArray, count: NDArray, closed: NDArray | None = None
) -> NDArray[np.float64]:
    """Per-pixel mean of the free samples; pixels never free are filled from around, and
    given the closed-SLM frame, the fill is that frame plus a smooth surface through its
    difference from the mean where pixels were free.

    Where the pinholes are few (the response's 4 x 5 frames on ``sim``), 62 % of the rows
    that streaks reach is never free, and under the blue end of a streak the background is
    10-25 times the pinhole's own light: a fill off by 0.5 % there is 5 % off in those bins,
    the same bins of every streak. A smooth fill misses the background's structure there;
    the closed frame has it but not the light that only the pinhole frames carry (stray
    light of the open pixels, a lamp's drift), which is smooth and the surface supplies.
    """
    known = count > 0
    background = np.divide(total, count, out=np.full(total.shape, np.nan), where=known)
    if known.all():
        return background
    if closed is not None and known.any():
        difference = np.where(known, background - closed, 0.0)
        surface = estimate_background(difference, ~known).image
        return np.where(known, background, closed + surface)
    filled = estimate_background(np.nan_to_num(background), ~known)
    return np.where(known, background, filled.image)


def _pixel_flags(data, geo: StreakGeometry, saturation: int, index: int, problems: list[str]):
    """Saturated or non-finite pixels under each open pixel's streak."""
    h, w = data.shape
    x0 = np.clip(np.floor(geo.x_left.min(axis=1)).astype(np.intp), 0, w - 1)
    x1 = np.clip(np.ceil(geo.x_right.max(axis=1)).astype(np.intp), 0, w - 1)
    y = np.clip(np.rint(geo.y.mean(axis=1)).astype(np.intp), 0, h - 1)
    bad = (data >= saturation) | ~np.isfinite(data)
    if not bad.any():
        return np.zeros(geo.rows.size, dtype=np.uint8)
    # Any bad pixel on the streak's centre row segment (cumulative sums per row).
    cum = np.concatenate([np.zeros((h, 1)), np.cumsum(bad, axis=1)], axis=1)
    hit = (cum[y, x1 + 1] - cum[y, x0]) > 0
    flags = np.where(hit, QUALITY_FLAGS["saturated"], 0).astype(np.uint8)
    for r, c in zip(geo.rows[hit][:5], geo.cols[hit][:5], strict=True):
        problems.append(
            f"frame {index}: streak of SLM pixel (u={c}, v={r}) is saturated or not finite"
        )
    if hit.sum() > 5:
        problems.append(f"frame {index}: {int(hit.sum()) - 5} more saturated streaks")
    return flags
