"""Superpixels of the guide image on the SLM grid, and the features they are built from.

SLIC on CIELAB features (OpenCV's float conversion: L 0-100), our own compiled version
(:mod:`sassi_bench.snapshot._slic`) with :data:`ITERATIONS` iterations; video
(:class:`~sassi_bench.snapshot.video.VideoPipeline`) clusters the features shrunk by
:data:`VIDEO_SHRINK` and starts each frame from the last frame's centres (``seeds``), one
kept per cell of the starting grid. The superpixels only place the samples; the regions
the cube is spread over come from the full-resolution re-segmentation around the samples
(:func:`~sassi_bench.snapshot.adaptive.segment_around_samples`). Why these choices, with
the measurements against OpenCV's and scikit-image's SLIC:
docs/notes/2026-11-29-snapshot-superpixels.md and ``benchmarks/bench_superpixels.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape
from sassi_bench.bundle import BundleError, CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot import _kernels, _slic

__all__ = ["Superpixels", "guide_features", "guide_on_slm", "superpixels"]

#: SLIC iterations (measurement: docs/notes/2026-11-29-snapshot-superpixels.md).
ITERATIONS = 2
#: Video's SLIC runs on the features shrunk by this factor
#: (docs/notes/2026-11-29-snapshot-superpixels.md).
VIDEO_SHRINK = 2

#: The guide images accepted: grey, one channel or RGB.
_GUIDE_SHAPES = [("H", "W"), ("H", "W", 1), ("H", "W", 3)]


def guide_on_slm(bundle: CalibrationBundle, guide: ArrayLike) -> NDArray[np.float32]:
    """The guide camera's image resampled onto the SLM grid, as float32 (H, W, C).

    Raises
    ------
    ProcedureError
        If the bundle has no guide homography, or the image is not a guide image.

    Examples
    --------
    Not run here (it needs captured frames)::

        guide_slm = guide_on_slm(bundle, rig.guide_camera.capture().data)
    """
    step = "snapshot guide image"
    if bundle.guide_to_slm is None:
        raise ProcedureError(
            step_error(
                step,
                f"bundle {bundle.rig_name}/{bundle.version} has no guide -> SLM homography",
                "run `sassi-bench calibrate guide` (or the full `sassi-bench calibrate`) and "
                "use the bundle it publishes",
            )
        )
    image = np.asarray(guide)
    check_shape(
        image,
        _GUIDE_SHAPES,
        step=step,
        name="the guide image",
        fix="pass the guide camera's (rows, cols) or (rows, cols, 3) image",
    )
    try:
        warped = bundle.warp_guide_to_slm(image.astype(np.float32, copy=False))
    except BundleError as exc:
        raise ProcedureError(str(exc)) from exc
    return warped if warped.ndim == 3 else warped[..., None]


def _check_slm_image(image: ArrayLike, shape: tuple[int, int] | None, step: str) -> NDArray:
    check_shape(
        image,
        _GUIDE_SHAPES,
        step=step,
        name="the guide image on the SLM grid",
        fix="pass an (H, W) or (H, W, 3) image on the SLM grid (guide_on_slm)",
        allow_empty=False,
    )
    array = np.asarray(image)
    if array.ndim == 2:
        array = array[..., None]
    if shape is not None:
        check_shape(
            array[..., 0],  # its (rows, cols)
            tuple(shape),
            step=step,
            name="the guide image",
            expected_for="the SLM",
            fix="warp the guide image onto the SLM grid first (guide_on_slm)",
        )
    return array


def guide_features(
    guide_slm: ArrayLike, shape: tuple[int, int] | None = None
) -> NDArray[np.float32]:
    """SLIC features of a guide image on the SLM grid: CIELAB for colour, ``100 * I / max``
    for grey, (H, W, C) float32. Any brightness scale is accepted (it is normalised by the
    image's maximum first).

    Examples
    --------
    >>> rgb = np.zeros((4, 5, 3), np.float32); rgb[..., 0] = 1.0
    >>> guide_features(rgb)[0, 0].astype(float).round(1).tolist()  # pure red
    [53.2, 80.1, 67.2]
    """
    step = "snapshot superpixels"
    array = _check_slm_image(guide_slm, shape, step)
    # One pass for the peak and the finiteness, one for the scaling (float32 throughout).
    scaled, finite = _slic.scaled_by_peak(np.ascontiguousarray(array, dtype=np.float32))
    if not finite:
        raise ProcedureError(
            step_error(step, "the guide image holds NaN or infinite values", "pass finite values")
        )
    if scaled.shape[2] == 1:
        return 100.0 * scaled
    return cv2.cvtColor(scaled, cv2.COLOR_RGB2Lab)


@dataclass(frozen=True)
class Superpixels:
    """A SLIC segmentation on the SLM grid.

    Attributes
    ----------
    labels
        (H, W) int32, 0 .. count - 1.
    features
        (H, W, C) float32 features they were built from (:func:`guide_features`).
    region_size
        Nominal superpixel side in SLM px.
    compactness
        SLIC's weight of space against colour.
    centres
        (K, 2) float32 (row, column) of the clusters' centres on the grid they were
        found on (shrunk by ``shrink``): a video's next frame can start from them.
    shrink
        The factor the features were shrunk by for the clustering.
    planes
        The features as (C, H, W) float32 planes (what the compiled loops read).
    """

    labels: NDArray[np.int32]
    features: NDArray[np.float32]
    region_size: int
    compactness: float
    centres: NDArray[np.float32] | None = None
    shrink: int = 1
    planes: NDArray[np.float32] | None = None

    @property
    def count(self) -> int:
        """Number of superpixels."""
        return int(self.labels.max()) + 1 if self.labels.size else 0


def superpixels(
    guide_slm: ArrayLike,
    n_segments: int = 1000,
    *,
    compactness: float = 10.0,
    iterations: int = ITERATIONS,
    shape: tuple[int, int] | None = None,
    shrink: int = 1,
    seeds: ArrayLike | None = None,
) -> Superpixels:
    """SLIC superpixels of a guide image on the SLM grid (compiled, :mod:`._slic`).

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, 3) guide image on the SLM grid (:func:`guide_on_slm`).
    n_segments
        Approximate number of superpixels.
    compactness
        Weight of space against colour (Lab units per region size).
    iterations
        SLIC iterations.
    shape
        The SLM (H, W) the image must have, if given.
    shrink
        Segment the features shrunk by this factor (2 x 2 means) and enlarge the labels
        back (nearest); 1: full size. Superpixels under 4 x ``shrink`` px a side are
        segmented at full size.
    seeds
        Centres to start from instead of a grid (``centres`` of the previous frame's
        superpixels, segmented with the same ``n_segments`` and ``shrink``).

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> image = np.repeat(np.repeat(rng.uniform(size=(4, 4, 3)), 16, 0), 16, 1)
    >>> sp = superpixels(image.astype(np.float32), 16)
    >>> sp.labels.shape, 12 <= sp.count <= 20
    ((64, 64), True)
    """
    step = "snapshot superpixels"
    features = guide_features(guide_slm, shape)
    h, w = features.shape[:2]
    if not (isinstance(n_segments, (int, np.integer)) and 1 <= n_segments <= h * w):
        raise ProcedureError(
            step_error(
                step, f"n_segments is {n_segments!r}", f"pass an integer between 1 and {h * w}"
            )
        )
    if not (isinstance(iterations, (int, np.integer)) and iterations >= 1):
        raise ProcedureError(step_error(step, f"iterations is {iterations!r}", "pass 1 or more"))
    region = max(2, round(float(np.sqrt(h * w / n_segments))))
    factor = int(shrink) if region >= 4 * int(shrink) and int(shrink) > 1 else 1
    planes = _kernels.planes(features)
    small = _slic.halve(planes) if factor == 2 else planes
    if factor > 2:
        small = np.stack(
            [cv2.resize(p, (max(1, w // factor), max(1, h // factor)), interpolation=cv2.INTER_AREA)
             for p in planes]
        )  # fmt: skip
    size = max(2, round(region / factor))
    centres = _slic.grid_centres(small, size)
    if seeds is not None:
        previous = np.asarray(seeds, dtype=np.float32)
        if previous.ndim != 2 or previous.shape[1] != 2 or not np.isfinite(previous).all():
            raise ProcedureError(
                step_error(
                    step,
                    f"the seeds (shape {previous.shape}) are not (K, 2) finite centres",
                    "pass the centres of the previous frame's superpixels",
                )
            )
        centres = _slic.carry_centres(previous, centres, small.shape[1], small.shape[2], size)
    grid = np.empty(small.shape[1:], np.int32)
    _slic.cluster(small, centres, size, float(compactness), int(iterations), grid)
    # Components under a quarter of a superpixel's area join a neighbour (OpenCV's rule).
    grid, _ = _slic.connect(grid, max(1, size * size // 4))
    labels = grid if factor == 1 else _slic.enlarge(grid, h, w)
    return Superpixels(labels, features, region, float(compactness), centres, factor, planes)
