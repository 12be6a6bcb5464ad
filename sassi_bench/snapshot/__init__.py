"""Snapshots: adaptive masks and reconstruction from one frame, on a calibration bundle.

The reference consumer of a bundle. It depends only on the public bundle API
(:mod:`sassi_bench.bundle`) and :mod:`sassi_bench.spectra` extraction, as a reconstruction
package outside the workbench would:

* :mod:`~sassi_bench.snapshot.masks`: the spacing rule (``bundle.mask_spacing()``) checked
  on a given mask; uniform and random masks under it;
* :mod:`~sassi_bench.snapshot.superpixels`: the guide image on the SLM grid, SLIC;
* :mod:`~sassi_bench.snapshot.adaptive`: the SASSI paper's adaptive mask;
* :mod:`~sassi_bench.snapshot.reconstruct`: spectra at the open pixels, then the cube by
  rank-1 per region; cubes on disk like scan cubes;
* :mod:`~sassi_bench.snapshot.guided`: the masked guided filter in a rank-6 spectral basis;
* :mod:`~sassi_bench.snapshot.factored`: both cubes in factored form, dense on demand;
* :mod:`~sassi_bench.snapshot.pipeline`: one frame from raw guide and spectral images to
  both cubes;
* :mod:`~sassi_bench.snapshot.video`: the per-frame pipeline of a video, frame after frame,
  spectra beside the segmentation on two threads;
* :mod:`~sassi_bench.snapshot.metrics`: PSNR (raw and after an affine fit), SSIM, spectral
  angle.
"""

from sassi_bench.snapshot.adaptive import (
    AdaptiveMask,
    adaptive_mask,
    place_samples,
    plan_image,
    planned_mask,
    segment_around_samples,
    snapshot_regions,
)
from sassi_bench.snapshot.factored import LowRankCube, Rank1Cube, spectral_basis
from sassi_bench.snapshot.guided import guided_cube, guided_factors
from sassi_bench.snapshot.masks import check_mask, mask_conflicts, random_mask, uniform_mask
from sassi_bench.snapshot.metrics import (
    affine_fit,
    band_psnr,
    mean_spectral_angle_deg,
    psnr,
    ssim,
)
from sassi_bench.snapshot.pipeline import (
    FrameReconstruction,
    adaptive_samples,
    reconstruct_frame,
)
from sassi_bench.snapshot.reconstruct import (
    guide_intensity,
    measure_samples,
    measure_with_background,
    rank1_cube,
    rank1_factors,
    snapshot_dataset,
    write_cube,
)
from sassi_bench.snapshot.superpixels import Superpixels, guide_features, guide_on_slm, superpixels
from sassi_bench.snapshot.video import VideoFrame, VideoPipeline

__all__ = [
    "AdaptiveMask",
    "FrameReconstruction",
    "LowRankCube",
    "Rank1Cube",
    "Superpixels",
    "VideoFrame",
    "VideoPipeline",
    "adaptive_mask",
    "adaptive_samples",
    "affine_fit",
    "band_psnr",
    "check_mask",
    "guide_features",
    "guide_intensity",
    "guide_on_slm",
    "guided_cube",
    "guided_factors",
    "mask_conflicts",
    "mean_spectral_angle_deg",
    "measure_samples",
    "measure_with_background",
    "place_samples",
    "plan_image",
    "planned_mask",
    "psnr",
    "random_mask",
    "rank1_cube",
    "rank1_factors",
    "reconstruct_frame",
    "segment_around_samples",
    "snapshot_dataset",
    "snapshot_regions",
    "spectral_basis",
    "ssim",
    "superpixels",
    "uniform_mask",
    "write_cube",
]
