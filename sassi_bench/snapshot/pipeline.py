"""One snapshot frame from raw images to cubes: what the SASSI camera does every frame.

:func:`reconstruct_frame` chains the package's steps for one frame: the guide image onto
the SLM grid, the regions around the samples, the spectra at the open pixels
(:func:`~sassi_bench.snapshot.reconstruct.measure_samples`), then rank-1 per region and the
masked guided filter. The validation (:mod:`sassi_bench.validate.snapshot`) scores its
output; ``sassi-bench snapshot take`` and ``snapshot reconstruct`` write it to disk.

The regions follow the samples the mask was drawn around: for an adaptive mask, the
superpixel centres of the guide image the mask was computed from (in video mode the
previous frame's), re-segmented on this frame's guide image smoothed as plans are
(:func:`~sassi_bench.snapshot.adaptive.snapshot_regions`), so the guide camera's noise does not
move their boundaries; for any other mask, every open pixel is a region centre. Rank-1
scales each region's spectrum by the unsmoothed guide image.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.bundle import CalibrationBundle, MaskSpacing
from sassi_bench.snapshot.adaptive import planned_mask, snapshot_regions
from sassi_bench.snapshot.factored import LowRankCube, Rank1Cube
from sassi_bench.snapshot.guided import guided_factors
from sassi_bench.snapshot.reconstruct import measure_samples, rank1_factors
from sassi_bench.snapshot.superpixels import guide_on_slm
from sassi_bench.spectra.deblur import SpectralDeblur

__all__ = ["FrameReconstruction", "adaptive_samples", "reconstruct_frame"]


@dataclass(frozen=True)
class FrameReconstruction:
    """One snapshot frame reconstructed.

    Attributes
    ----------
    mask
        (H, W) bool: the open SLM pixels.
    samples
        (N, 2) int32 (row, column): the regions' centres.
    labels
        (H, W) int32: the region (index into ``samples``) of every SLM pixel.
    guide_slm
        (H, W, 3) float32: the frame's guide image on the SLM grid.
    spectra
        (M, B) float64: the spectra of the open pixels (row-major order), in ``units``.
    units
        Units of the spectra and the cubes.
    rank1_factored
        The rank-1 cube in factored form (labels, per-pixel scale, region spectra).
    guided_factored
        The guided-filter cube in its rank-6 spectral basis.
    """

    mask: NDArray[np.bool_]
    samples: NDArray[np.int32]
    labels: NDArray[np.int32]
    guide_slm: NDArray[np.float32]
    spectra: NDArray[np.float64]
    units: str
    rank1_factored: Rank1Cube
    guided_factored: LowRankCube

    @cached_property
    def rank1(self) -> NDArray[np.float32]:
        """(H, W, B) float32 rank-1 cube, materialised on first use."""
        return self.rank1_factored.dense()

    @cached_property
    def guided(self) -> NDArray[np.float32]:
        """(H, W, B) float32 guided-filter cube, materialised on first use."""
        return self.guided_factored.dense()


def adaptive_samples(
    mask: NDArray[np.bool_],
    planned_on: NDArray[np.floating],
    spacing: MaskSpacing,
    *,
    compactness: float,
) -> NDArray[np.int32]:
    """The region centres of a mask: the adaptive samples when ``mask`` is the planned
    mask of ``planned_on`` (:func:`~sassi_bench.snapshot.adaptive.planned_mask` of a guide
    image on the SLM grid), else every open pixel.

    The planned mask is deterministic, so recomputing it from the guide image it was
    planned on recovers its samples; a mask that differs (a uniform, random or user mask,
    or other settings) falls back to its open pixels.

    Examples
    --------
    Not run here (it needs captured frames)::

        samples = adaptive_samples(mask, guide_on_slm(bundle, preview), spacing,
                                   compactness=10.0)
    """
    planned = planned_mask(planned_on, spacing, compactness=compactness)
    if planned.mask.shape == mask.shape and np.array_equal(planned.mask, mask):
        return planned.samples
    return np.argwhere(mask).astype(np.int32)


def reconstruct_frame(
    bundle: CalibrationBundle,
    guide: ArrayLike,
    spectral: ArrayLike,
    mask: NDArray[np.bool_],
    *,
    exposure_s: float,
    samples: ArrayLike | None = None,
    compactness: float = 10.0,
    guided_radius: int | None = None,
    guided_eps: float = 1e-3,
    deblur: SpectralDeblur | None = None,
    closed: ArrayLike | None = None,
) -> FrameReconstruction:
    """Reconstruct one snapshot frame by rank-1 per region and by the masked guided filter.

    Parameters
    ----------
    bundle
        The calibration bundle (it needs a guide homography).
    guide
        The frame's raw guide image (guide camera rows, columns, 3).
    spectral
        The frame's raw spectral image.
    mask
        (H, W) bool: the mask the SLM showed.
    exposure_s
        The spectral frame's exposure; spectra are per second.
    samples
        (N, 2) (row, column) region centres (see :func:`adaptive_samples`); None: every
        open pixel.
    compactness
        SLIC's weight of space against colour in the re-segmentation (drawn on the guide
        image smoothed as plans are, :func:`~sassi_bench.snapshot.adaptive.snapshot_regions`).
    guided_radius, guided_eps
        The guided filter's window radius (None: about nine open pixels a window) and ridge.
    deblur
        The within-streak unmixing; built from the bundle when None (pass one to reconstruct
        many frames).
    closed
        The spectral frame of the closed SLM at the same exposure, when taken: the
        background of the spectra (see :func:`~sassi_bench.snapshot.reconstruct.measure_samples`).

    Returns
    -------
    FrameReconstruction

    Examples
    --------
    Not run here (it needs captured frames)::

        frame = reconstruct_frame(bundle, guide, spectral, mask, exposure_s=0.05)
        frame.rank1_factored.shape == (*bundle.slm_shape, bundle.wavelengths.size)
        # True
    """
    guide_slm = guide_on_slm(bundle, guide)
    mask = np.asarray(mask, dtype=bool)
    centres = np.argwhere(mask) if samples is None else np.asarray(samples)
    centres = centres.astype(np.int32)
    labels = snapshot_regions(guide_slm, centres, compactness=compactness)
    spectra, units = measure_samples(
        spectral, mask, bundle, exposure_s=exposure_s, deblur=deblur, closed=closed
    )
    return FrameReconstruction(
        mask=mask,
        samples=centres,
        labels=labels,
        guide_slm=guide_slm,
        spectra=spectra,
        units=units,
        rank1_factored=rank1_factors(guide_slm, labels, mask, spectra),
        guided_factored=guided_factors(
            guide_slm, mask, spectra, radius=guided_radius, eps=guided_eps
        ),
    )
