"""Adaptive masks: the SASSI paper's sampling from superpixels of the guide image.

1. Every superpixel's centroid is a first sample.
2. The spacing rule is enforced: a sample that the samples before it forbid moves to the
   nearest free pixel of its own superpixel, or is dropped when none is free.
3. The guide image is re-segmented around the samples (one SLIC assignment pass with the
   samples as fixed centres, each reaching :data:`REACH_SIDES` mean region sides), so
   every sample owns a region.
4. Every further pixel that keeps the rule is opened, so the mask measures as many streaks
   as the camera can hold; these extra pixels fall in the samples' regions and are
   measured with them. By default the pixels the samples represent worst (the 5 % whose
   features differ most from those of the best sample within one region side) are tried
   first, worst first, then the rest row by row: thin structures that no superpixel
   isolates (PCB tracks) get pixels, more of them than row order or a random mask of the
   same size reach (``docs/notes/2026-12-01-measured-in-code-comments.md``).

Steps 1, 2 and 4 are one compiled pass (:mod:`sassi_bench.snapshot._kernels`); step 3 is
:func:`segment_around_samples`, public because video mode re-segments frame ``t``'s guide
image around the samples taken at ``t - 1``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from sassi_bench._shared.arrays import check_shape
from sassi_bench.bundle import MaskSpacing
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot import _kernels
from sassi_bench.snapshot.masks import MaskBuilder
from sassi_bench.snapshot.superpixels import Superpixels, guide_features

__all__ = [
    "AdaptiveMask",
    "adaptive_mask",
    "guide_rank1_error",
    "place_samples",
    "plan_image",
    "planned_mask",
    "segment_around_samples",
    "snapshot_regions",
]

#: How far a sample's region may reach, in mean region sides ``S`` each way (Chebyshev).
#: SLIC searches ``S`` each way (a 2S x 2S window, Achanta et al. 2012), which suits centres
#: on a near-regular grid; an adaptive mask's samples are sparse and uneven (rows a pitch
#: apart, far apart along a row), so such regions stop short of pixels of their own colour
#: and leave them to a sample of another. The SASSI authors' ``slic_update`` searches 2S
#: each way, as here (measurement: docs/notes/2026-11-29-snapshot-regions.md).
REACH_SIDES = 2
#: The reach of the regions the residual-first fill (step 4) judges coverage by: SLIC's
#: ``S``. A pixel is badly represented when no sample of its colour is near; with 2S one
#: track's samples stand for the next track's pixels, and the fill reaches fewer tracks
#: (``docs/notes/2026-12-01-measured-in-code-comments.md``).
FILL_REACH_SIDES = 1
#: Gaussian sigma (SLM px) of the smoothing the guide image gets before a plan is drawn
#: from it and before a snapshot's regions are drawn around the plan's samples: enough to
#: take the guide camera's pixel noise out of the superpixels and the region boundaries,
#: well under a region's size.
PLAN_SMOOTHING_PX = 1.0
#: The superpixel counts :func:`planned_mask` draws candidate masks for, as factors on
#: :func:`default_segments`.
PLAN_SEGMENT_FACTORS = (1.0, 0.9, 1.1, 0.8, 1.2, 0.85)


@dataclass(frozen=True)
class AdaptiveMask:
    """An adaptive mask and the regions its samples own.

    Attributes
    ----------
    mask
        (H, W) bool: every open pixel (samples and the pixels added to fill the SLM).
    samples
        (N, 2) int32 (row, column) of the samples, the regions' centres.
    labels
        (H, W) int32: the sample (index into ``samples``) whose region each SLM pixel is in.
    """

    mask: NDArray[np.bool_]
    samples: NDArray[np.int32]
    labels: NDArray[np.int32]

    @property
    def open_pixels(self) -> NDArray[np.intp]:
        """(M, 2) (row, column) of every open pixel, row-major order."""
        return np.argwhere(self.mask)


def place_samples(
    superpixel_labels: ArrayLike, spacing: MaskSpacing, *, fill: bool = True
) -> tuple[NDArray[np.bool_], NDArray[np.int32]]:
    """Steps 1, 2 and (with ``fill``) 4: the mask and its samples, given superpixels.

    Parameters
    ----------
    superpixel_labels
        (H, W) integer labels on the SLM grid, 0 .. K - 1 (negative: no superpixel).
    spacing
        The rule (:meth:`CalibrationBundle.mask_spacing`).
    fill
        Also open every further pixel that keeps the rule.

    Returns
    -------
    mask : ndarray
        (H, W) bool.
    samples : ndarray
        (N, 2) int32 (row, column), N <= K, in superpixel order.

    Examples
    --------
    >>> spacing = MaskSpacing(np.full((8, 40), 4), np.full((8, 40), 4), 3, 3.0, 3.0)
    >>> labels = np.repeat(np.arange(4), 10)[None, :].repeat(8, 0)  # four 10-px strips
    >>> mask, samples = place_samples(labels, spacing, fill=False)
    >>> samples.tolist()  # centroids at columns 4.5, 14.5, ...: all fit
    [[4, 5], [4, 15], [4, 25], [4, 35]]
    """
    labels = np.ascontiguousarray(superpixel_labels, dtype=np.int32)
    check_shape(
        labels,
        spacing.slm_shape,
        step="adaptive mask",
        name="the superpixel label image",
        expected_for="the SLM",
        fix="segment the guide image warped onto the SLM grid (guide_on_slm)",
    )
    n_labels = int(labels.max()) + 1 if labels.size else 0
    builder = MaskBuilder.empty(spacing)
    samples = np.empty((max(n_labels, 0), 2), np.int32)
    owner = np.empty(max(n_labels, 0), np.int32)
    n = _kernels.place_samples(
        labels,
        n_labels,
        *builder.rule,
        builder.blocked,
        builder.row_cols,
        builder.row_count,
        builder.mask,
        samples,
        owner,
    )
    if fill:
        builder.fill()
    return builder.mask, samples[:n].copy()


def segment_around_samples(
    guide_slm: ArrayLike,
    samples: ArrayLike,
    *,
    compactness: float = 10.0,
    features: ArrayLike | None = None,
    planes: NDArray[np.float32] | None = None,
    reach: float = REACH_SIDES,
) -> NDArray[np.int32]:
    """Step 3: give every SLM pixel to a sample, by one SLIC assignment pass.

    Each pixel within ``reach * S`` (Chebyshev) of a sample, ``S = sqrt(H W / N)`` the
    mean region side, takes the sample minimising
    ``|f - f_s|^2 + (compactness / S)^2 |p - p_s|^2`` (SLIC's distance; ``f`` the CIELAB
    features of :func:`guide_features`, ``f_s`` their mean over the 3 x 3 pixels around
    the sample, ``p`` the position). Pixels no sample reaches take the nearest sample.

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, 3) guide image on the SLM grid.
    samples
        (N, 2) (row, column) of the samples, N >= 1.
    compactness
        SLIC's weight of space against colour.
    features
        Precomputed :func:`guide_features` of ``guide_slm`` (skips the conversion).
    planes
        The same features as (C, H, W) float32 planes (:attr:`Superpixels.planes`; skips
        the rearrangement).
    reach
        How far a region may reach, in mean region sides (:data:`REACH_SIDES`).

    Returns
    -------
    ndarray
        (H, W) int32: index of each pixel's sample.

    Examples
    --------
    >>> image = np.zeros((6, 10), np.float32); image[:, 5:] = 1.0
    >>> segment_around_samples(image, [[2, 1], [3, 8]])[0].tolist()
    [0, 0, 0, 0, 0, 1, 1, 1, 1, 1]
    """
    feats = guide_features(guide_slm) if features is None else np.asarray(features, np.float32)
    h, w = feats.shape[:2]
    points = np.asarray(samples)
    if (
        points.ndim != 2
        or points.shape[1] != 2
        or points.shape[0] == 0
        or points.dtype.kind not in "iu"
        or (points < 0).any()
        or (points[:, 0] >= h).any()
        or (points[:, 1] >= w).any()
    ):
        raise ProcedureError(
            step_error(
                "snapshot segmentation",
                f"the samples (shape {points.shape}, dtype {points.dtype}) are not (row, column) "
                f"pixels of the {h} x {w} SLM",
                "pass an (N, 2) integer array of pixels inside the SLM, N >= 1",
            )
        )
    points = np.ascontiguousarray(points, dtype=np.int64)
    side = max(1.0, float(np.sqrt(h * w / points.shape[0])))
    labels = np.full((h, w), -1, np.int32)
    distance = np.full((h, w), np.inf, np.float32)
    if planes is None or planes.shape[1:] != (h, w):
        planes = _kernels.planes(np.ascontiguousarray(feats.reshape(h, w, -1)))
    _kernels.assign_to_samples(
        planes,
        points,
        int(np.ceil(reach * side)),
        np.float32((compactness / side) ** 2),
        labels,
        distance,
    )
    missing = np.nonzero(labels < 0)
    if missing[0].size:
        # Nearest sample for pixels beyond every sample's reach (sparse or uneven samples);
        # of equally near samples, any one.
        _, nearest = cKDTree(points).query(np.stack(missing, axis=1))
        labels[missing] = nearest
    return labels


def adaptive_mask(
    guide_slm: ArrayLike,
    spacing: MaskSpacing,
    *,
    segments: Superpixels | None = None,
    n_segments: int | None = None,
    compactness: float = 10.0,
    fill: str | None = "residual",
    residual_share: float = 0.05,
) -> AdaptiveMask:
    """The adaptive mask of a guide image on the SLM grid (all four steps).

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, 3) guide image on the SLM grid (:func:`guide_on_slm`).
    spacing
        The rule (:meth:`CalibrationBundle.mask_spacing`).
    segments
        Superpixels already computed (:func:`superpixels`); else they are computed here.
    n_segments
        Superpixels to ask for; default: as many as a uniform lattice under the rule holds.
    compactness
        SLIC's weight of space against colour (superpixels and re-segmentation).
    fill
        Step 4: ``"residual"`` (the worst-represented pixels first, then row order),
        ``"raster"`` (row order) or None (samples only).
    residual_share
        Share of the SLM pixels tried first by the ``"residual"`` fill.

    Examples
    --------
    Not run here (it needs captured frames)::

        guide_slm = guide_on_slm(bundle, guide)
        result = adaptive_mask(guide_slm, bundle.mask_spacing())
        result.mask.sum(), len(result.samples)
    """
    from sassi_bench.snapshot.superpixels import superpixels

    h, w = spacing.slm_shape
    if segments is None:
        if n_segments is None:
            n_segments = default_segments(spacing)
        segments = superpixels(
            guide_slm, n_segments, compactness=compactness, shape=spacing.slm_shape
        )
    else:
        check_shape(
            segments.labels,
            (h, w),
            step="adaptive mask",
            name="the superpixel label image",
            expected_for="the SLM",
            fix="segment the guide image warped onto the SLM grid (guide_on_slm)",
        )
    if fill not in ("residual", "raster", None):
        raise ProcedureError(
            step_error("adaptive mask", f"fill is {fill!r}", 'pass "residual", "raster" or None')
        )
    mask, samples = place_samples(segments.labels, spacing, fill=False)
    if samples.shape[0] == 0:
        raise ProcedureError(
            step_error("adaptive mask", "no superpixel could be sampled", "pass a guide image")
        )
    features = segments.features
    labels = segment_around_samples(
        guide_slm, samples, compactness=compactness, features=features, planes=segments.planes
    )
    if fill is not None:
        builder = MaskBuilder.empty(spacing)
        builder.fill(np.ravel_multi_index((samples[:, 0], samples[:, 1]), (h, w)))
        if fill == "residual":
            # How badly the sample nearest in colour within S stands for each pixel (squared
            # feature distance).
            near = segment_around_samples(
                guide_slm, samples, compactness=compactness, features=features,
                planes=segments.planes, reach=FILL_REACH_SIDES,
            )  # fmt: skip
            centres = features[samples[:, 0], samples[:, 1]]
            residual = np.einsum("ijc,ijc->ij", features - centres[near], features - centres[near])
            flat = residual.ravel()
            count = max(1, int(residual_share * flat.size))
            worst = np.argpartition(flat, flat.size - count)[flat.size - count :]
            builder.fill(worst[np.argsort(-flat[worst], kind="stable")])
        builder.fill()
        mask = builder.mask
    return AdaptiveMask(mask, samples, labels)


def default_segments(spacing: MaskSpacing) -> int:
    """As many superpixels as a uniform lattice under the rule has pixels.

    Examples
    --------
    >>> default_segments(MaskSpacing(np.full((60, 100), 9), np.full((60, 100), 9), 5, 3, 3))
    120
    """
    h, w = spacing.slm_shape
    return max(1, int(np.ceil(h / spacing.pitch) * np.ceil(w / spacing.uniform_step)))


def guide_rank1_error(guide_slm: ArrayLike, plan: AdaptiveMask) -> float:
    """How well ``plan`` would reconstruct the guide image itself: the mean squared error of
    rank-1 per region (:func:`~sassi_bench.snapshot.reconstruct.rank1_factors`) fed the
    guide's own colour at the open pixels, against the guide (its peak scaled to 1).

    The guide is the one image of the scene a plan can be judged on before the spectral
    frame exists; a mask that leaves a patch of colour without a sample of its own
    reconstructs the guide badly for the same reason it reconstructs the spectra badly.

    Examples
    --------
    >>> image = np.zeros((6, 10, 3), np.float32); image[:, 5:, 0] = 1.0
    >>> samples = np.array([[2, 1], [3, 8]], np.int32)
    >>> mask = np.zeros((6, 10), bool); mask[2, 1] = mask[3, 8] = True
    >>> labels = segment_around_samples(image, samples)
    >>> guide_rank1_error(image, AdaptiveMask(mask, samples, labels))
    0.0
    """
    from sassi_bench.snapshot.reconstruct import rank1_factors

    image = np.asarray(guide_slm, np.float32)
    if image.ndim == 2:
        image = image[..., None]
    image = image / max(float(image.max()), np.finfo(np.float32).tiny)
    rows, cols = np.nonzero(plan.mask)
    cube = rank1_factors(image, plan.labels, plan.mask, image[rows, cols].astype(np.float64))
    return float(np.mean((cube.dense() - image) ** 2))


def plan_image(
    guide_slm: ArrayLike, smoothing_px: float = PLAN_SMOOTHING_PX
) -> NDArray[np.float32]:
    """The guide image that plans and regions are drawn on: smoothed by a Gaussian of
    ``smoothing_px`` SLM pixels (0: unchanged), so that the guide camera's pixel noise
    moves neither the superpixels nor the region boundaries.

    A snapshot's regions come from the frame's own guide image, whose noise differs from
    the preview's: drawn on the raw image, a small bright patch (a specular highlight) goes
    to one sample or another with the noise, and rank-1 gives it a spectrum of another
    colour (``benchmarks/bench_snapshot_noise.py``; docs/notes/2026-11-29-snapshot-regions.md).

    Examples
    --------
    >>> image = np.zeros((9, 9, 1), np.float32); image[4, 4] = 1.0
    >>> smooth = plan_image(image)
    >>> smooth.shape, round(float(smooth[4, 4, 0]), 2), round(float(smooth.sum()), 2)
    ((9, 9, 1), 0.16, 1.0)
    """
    import cv2

    image = np.asarray(guide_slm, np.float32)
    if smoothing_px > 0:
        # OpenCV drops a single channel's axis; the shape is kept.
        image = cv2.GaussianBlur(image, (0, 0), float(smoothing_px)).reshape(image.shape)
    return image


def snapshot_regions(
    guide_slm: ArrayLike, samples: ArrayLike, *, compactness: float = 10.0
) -> NDArray[np.int32]:
    """A snapshot frame's regions: its guide image, smoothed as plans are
    (:func:`plan_image`), re-segmented around the samples (:func:`segment_around_samples`).

    Examples
    --------
    >>> image = np.zeros((6, 10), np.float32); image[:, 5:] = 1.0
    >>> snapshot_regions(image, [[2, 1], [3, 8]])[0].tolist()
    [0, 0, 0, 0, 0, 1, 1, 1, 1, 1]
    """
    return segment_around_samples(plan_image(guide_slm), samples, compactness=compactness)


def planned_mask(
    guide_slm: ArrayLike,
    spacing: MaskSpacing,
    *,
    compactness: float = 10.0,
    smoothing_px: float = PLAN_SMOOTHING_PX,
    segment_factors: tuple[float, ...] = PLAN_SEGMENT_FACTORS,
) -> AdaptiveMask:
    """The adaptive mask a snapshot shows: of the adaptive masks of the smoothed guide image
    for a few superpixel counts, the one whose rank-1 reconstructs the guide best
    (:func:`guide_rank1_error`).

    One adaptive mask depends on the guide camera's noise: its superpixels, and so where
    the spacing rule lets samples sit, move with it, and a mask that happens to leave a
    patch of colour without a sample of its own reconstructs that patch with another's
    spectrum. Smoothing takes the pixel noise out of the superpixels, and choosing among
    several masks by how well each reproduces the guide keeps one that covers the scene's
    colours (the figures and their spread over noise realisations:
    ``benchmarks/bench_snapshot_noise.py``). Deterministic: the same guide image gives the
    same mask, so :func:`~sassi_bench.snapshot.pipeline.adaptive_samples` recovers its
    samples.

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, 3) guide image on the SLM grid (:func:`guide_on_slm`).
    spacing
        The rule (:meth:`CalibrationBundle.mask_spacing`).
    compactness
        SLIC's weight of space against colour.
    smoothing_px
        Gaussian sigma (SLM px) applied to the guide first (0: none).
    segment_factors
        Superpixel counts of the candidates, as factors on :func:`default_segments`.

    Returns
    -------
    AdaptiveMask
        The chosen mask, its samples and their regions on the smoothed guide.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        plan = planned_mask(guide_on_slm(bundle, preview), bundle.mask_spacing())
    """
    image = plan_image(guide_slm, smoothing_px)
    base = default_segments(spacing)
    counts = dict.fromkeys(max(1, round(base * factor)) for factor in segment_factors)
    if not counts:
        raise ProcedureError(
            step_error("adaptive mask", "no segment factor given", "pass one factor or more")
        )
    best, best_error = None, np.inf
    for count in counts:
        plan = adaptive_mask(image, spacing, n_segments=count, compactness=compactness)
        error = guide_rank1_error(image, plan)
        if error < best_error:
            best, best_error = plan, error
    return best
