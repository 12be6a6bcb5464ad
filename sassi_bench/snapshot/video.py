"""Video-rate snapshots: the per-frame pipeline with its state carried from frame to frame.

Frame ``t`` was taken with the mask planned on guide image ``t - 1`` (its samples are the
regions' centres). :meth:`VideoPipeline.process` then, for frame ``t``:

* on one thread, the spectra of the open pixels (:func:`measure_with_background`), the
  dense mask's background refined once from frame ``t - 1``'s instead of from scratch,
  starting from the streak model of frame ``t``'s mask that was built during frame
  ``t - 1`` (:func:`~sassi_bench.snapshot.reconstruct.mask_model`); then the streak model
  of frame ``t + 1``'s mask, as soon as the other thread has planned it;
* on the other, at the same time: guide ``t`` warped onto the SLM grid, its superpixels
  (SLIC on the features shrunk by 2, starting from frame ``t - 1``'s centres: see
  :mod:`~sassi_bench.snapshot.superpixels`), the mask of frame ``t + 1``
  (:func:`~sassi_bench.snapshot.adaptive.place_samples`, the row-order fill), handed to
  the first thread, and the re-segmentation of guide ``t`` around frame ``t``'s samples;
* then the rank-1 cube, kept factored (:class:`~sassi_bench.snapshot.factored.Rank1Cube`),
  from the region sums of the few open pixels (the per-pixel scale and labels are made on
  the second thread).

The two threads run compiled code that releases the GIL (numba, OpenCV), so two cores work
at once; the streak model moves to the first thread so that the two take about as long
(``benchmarks/bench_snapshot.py``). Each step's seconds are kept, for the benchmark and
the live mode's progress line.
"""

from __future__ import annotations

import time
from concurrent.futures import Future, ThreadPoolExecutor, wait
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle, MaskSpacing
from sassi_bench.snapshot.adaptive import default_segments, place_samples, segment_around_samples
from sassi_bench.snapshot.factored import Rank1Cube
from sassi_bench.snapshot.reconstruct import (
    WARM_BACKGROUND_PASSES,
    MaskModel,
    guide_intensity,
    mask_model,
    measure_with_background,
    rank1_factors,
)
from sassi_bench.snapshot.superpixels import VIDEO_SHRINK, guide_on_slm, superpixels
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.geometry import reached_rows
from sassi_bench.spectra.offset import Background, BlockBackground

__all__ = ["STEPS", "VideoFrame", "VideoPipeline"]

#: The timed steps of a frame, in pipeline order.
STEPS = ("warp", "superpixels", "mask", "model", "resegment", "spectra", "rank1")


@dataclass(frozen=True)
class VideoFrame:
    """One frame of a snapshot video, reconstructed.

    Attributes
    ----------
    mask
        (H, W) bool: the mask the frame was taken with.
    samples
        (N, 2) int32: its samples (the regions' centres).
    guide_slm
        (H, W, C) float32: the frame's guide image on the SLM grid.
    spectra
        (M, B) float64: spectra of the open pixels (row-major order), in ``units``.
    units
        Units of the spectra and the cube.
    rank1
        The rank-1 cube in factored form (dense on demand: ``rank1.dense()``).
    next_mask, next_samples
        The mask (and samples) planned on this frame's guide image, for the next frame.
    seconds
        Seconds of every step of :data:`STEPS`, and ``"total"`` (wall clock: the two
        threads overlap, so it is less than the steps' sum).
    cpu_seconds
        CPU seconds of every step (of the thread that ran it): what other work on a shared
        machine does not inflate.
    """

    mask: NDArray[np.bool_]
    samples: NDArray[np.int32]
    guide_slm: NDArray[np.float32]
    spectra: NDArray[np.float64]
    units: str
    rank1: Rank1Cube
    next_mask: NDArray[np.bool_]
    next_samples: NDArray[np.int32]
    seconds: dict[str, float] = field(default_factory=dict)
    cpu_seconds: dict[str, float] = field(default_factory=dict)


def _timed(times: tuple[dict[str, float], dict[str, float]], name: str, fn, *args, **kwargs):
    """``fn(*args, **kwargs)``, its wall and thread CPU seconds written under ``name``."""
    wall, cpu = time.perf_counter(), time.thread_time()
    out = fn(*args, **kwargs)
    times[0][name] = time.perf_counter() - wall
    times[1][name] = time.thread_time() - cpu
    return out


class VideoPipeline:
    """The per-frame pipeline of a snapshot video (see the module docstring).

    Parameters
    ----------
    bundle
        The calibration bundle (it needs a guide homography).
    spacing
        The rule every mask keeps (``bundle.mask_spacing(row_pitch=...)``).
    compactness
        SLIC's weight of space against colour (superpixels and re-segmentation).
    n_segments
        Superpixels per frame; default: the lattice size of the rule.
    deblur
        The within-streak unmixing; built from the bundle when None.
    threads
        2: spectra beside the segmentation; 1: one after the other.
    background_passes
        Background refinements of a dense mask from the previous frame's background (None:
        :data:`~sassi_bench.snapshot.reconstruct.WARM_BACKGROUND_PASSES`); the first frame
        refines from scratch.

    Examples
    --------
    Not run here (it needs captured frames)::

        pipeline = VideoPipeline(bundle, bundle.mask_spacing(row_pitch=8))
        mask, samples = pipeline.plan(preview_guide)
        frame = pipeline.process(guide, spectral, mask, samples, exposure_s=0.05)
        mask, samples = frame.next_mask, frame.next_samples
    """

    def __init__(
        self,
        bundle: CalibrationBundle,
        spacing: MaskSpacing,
        *,
        compactness: float = 10.0,
        n_segments: int | None = None,
        deblur: SpectralDeblur | None = None,
        threads: int = 2,
        background_passes: int | None = None,
    ) -> None:
        self.bundle = bundle
        self.spacing = spacing
        self.compactness = float(compactness)
        self.n_segments = n_segments or default_segments(spacing)
        self.deblur = deblur if deblur is not None else SpectralDeblur.from_bundle(bundle)
        self.background_passes = background_passes
        self._pool = ThreadPoolExecutor(max_workers=1) if threads >= 2 else None
        self._background: Background | BlockBackground | None = None
        self._centres: NDArray[np.float32] | None = None  # the last superpixels' centres
        # The camera's frame shape and the rows the SLM's light reaches there (first frame).
        self._camera: tuple[tuple[int, int], tuple[int, int]] | None = None
        # The next frame's mask and its model, prepared on the segmentation thread.
        self._prepared: tuple[NDArray[np.bool_], MaskModel] | None = None

    def close(self) -> None:
        """Stop the spectra thread."""
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def __enter__(self) -> VideoPipeline:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _warp(self, guide: ArrayLike):
        guide_slm = guide_on_slm(self.bundle, guide)
        return guide_slm, guide_intensity(guide_slm)

    def _superpixels(self, guide_slm):
        segments = superpixels(
            guide_slm, self.n_segments, compactness=self.compactness,
            shape=self.spacing.slm_shape, shrink=VIDEO_SHRINK, seeds=self._centres,
        )  # fmt: skip
        self._centres = segments.centres
        return segments

    def _resegment(self, guide_slm, samples, segments):
        labels = segment_around_samples(
            guide_slm, samples, compactness=self.compactness, features=segments.features,
            planes=segments.planes,
        )  # fmt: skip
        return labels.astype(np.intp)  # the rank-1 cube's labels, made here, off the join

    def _prepare(self, mask: NDArray[np.bool_]) -> tuple[NDArray[np.bool_], MaskModel] | None:
        """The next frame's :class:`MaskModel` (once the camera's frame size is known)."""
        if self._camera is None:
            return None
        shape, rows = self._camera
        return mask, mask_model(self.bundle, mask, shape, camera_rows=rows)

    def _segment(self, guide: ArrayLike, samples: NDArray[np.int32], times, handoff: Future):
        guide_slm, intensity = _timed(times, "warp", self._warp, guide)
        segments = _timed(times, "superpixels", self._superpixels, guide_slm)
        next_mask, next_samples = _timed(
            times, "mask", place_samples, segments.labels, self.spacing
        )
        handoff.set_result(next_mask)  # the spectra thread builds its model next
        labels = _timed(times, "resegment", self._resegment, guide_slm, samples, segments)
        return guide_slm, intensity, labels, next_mask, next_samples

    def _spectra_then_model(self, spectral, mask, exposure_s, prepared, times, handoff):
        """This frame's spectra, then the next frame's streak model from its mask alone
        (handed over by the segmentation thread as soon as it is planned): the model is
        built before its frame comes, on the thread that has time for it."""
        measured = self._spectra(spectral, mask, exposure_s, prepared, times)
        try:
            next_mask = handoff.result()
        except BaseException:  # the segmentation failed: it raises in the caller
            return measured, None
        return measured, _timed(times, "model", self._prepare, next_mask)

    def _measure(self, spectral, mask: NDArray[np.bool_], exposure_s: float, prepared):
        shape = tuple(np.shape(spectral))
        if self._camera is None or self._camera[0] != shape:
            self._camera = (shape, reached_rows(self.bundle, shape[0]))
        if (
            prepared is None
            or prepared[1].camera_shape != shape
            or (prepared[0] is not mask and not np.array_equal(prepared[0], mask))
        ):
            prepared = self._prepare(mask)  # the first frame, or a mask of the caller's
        model = prepared[1]
        passes = None  # the first frame, or a sparse mask: as a single snapshot
        if isinstance(self._background, BlockBackground):  # a dense mask's, carried over
            passes = self.background_passes
            if passes is None:
                passes = WARM_BACKGROUND_PASSES
        spectra, units, background = measure_with_background(
            spectral, mask, self.bundle, exposure_s=exposure_s, deblur=self.deblur,
            background_passes=passes, background_start=self._background, prepared=model,
        )  # fmt: skip
        pixels = np.stack([model.rows, model.cols], axis=1)  # the spectra's order
        return pixels, spectra, units, background

    def _spectra(self, spectral, mask, exposure_s: float, prepared, times):
        return _timed(times, "spectra", self._measure, spectral, mask, exposure_s, prepared)

    def plan(self, guide: ArrayLike) -> tuple[NDArray[np.bool_], NDArray[np.int32]]:
        """The first frame's mask and samples, from a preview guide image.

        Parameters
        ----------
        guide
            A raw guide-camera image.

        Returns
        -------
        mask : ndarray
            (H, W) bool.
        samples : ndarray
            (N, 2) int32.
        """
        guide_slm = guide_on_slm(self.bundle, guide)
        return place_samples(self._superpixels(guide_slm).labels, self.spacing)

    def process(
        self,
        guide: ArrayLike,
        spectral: ArrayLike,
        mask: NDArray[np.bool_],
        samples: NDArray[np.int32],
        *,
        exposure_s: float,
    ) -> VideoFrame:
        """Reconstruct one frame and plan the next frame's mask.

        Parameters
        ----------
        guide, spectral
            The frame's raw guide and spectral images.
        mask, samples
            The mask the frame was taken with and its samples (from :meth:`plan` or the
            previous frame's ``next_mask``, ``next_samples``).
        exposure_s
            The spectral exposure; spectra are per second.

        Returns
        -------
        VideoFrame
        """
        start = time.perf_counter()
        times: tuple[dict[str, float], dict[str, float]] = ({}, {})
        mask = np.asarray(mask, dtype=bool)
        samples = np.asarray(samples, dtype=np.int32)
        prepared, self._prepared = self._prepared, None
        handoff: Future = Future()
        arguments = (spectral, mask, exposure_s, prepared, times, handoff)
        if self._pool is not None:
            future = self._pool.submit(self._spectra_then_model, *arguments)
            try:
                segmented = self._segment(guide, samples, times, handoff)
            except BaseException as exc:
                if not handoff.done():
                    handoff.set_exception(exc)
                wait([future])  # let the spectra thread finish before raising
                raise
            measured, next_prepared = future.result()
        else:
            measured = self._spectra(spectral, mask, exposure_s, prepared, times)
            segmented = self._segment(guide, samples, times, handoff)
            next_prepared = _timed(times, "model", self._prepare, segmented[3])
        pixels, spectra, units, background = measured
        guide_slm, intensity, labels, next_mask, next_samples = segmented
        self._prepared = next_prepared
        self._background = background
        rank1 = _timed(times, "rank1", rank1_factors, intensity, labels, pixels, spectra)
        times[0]["total"] = time.perf_counter() - start
        return VideoFrame(
            mask, samples, guide_slm, spectra, units, rank1, next_mask, next_samples, *times
        )
