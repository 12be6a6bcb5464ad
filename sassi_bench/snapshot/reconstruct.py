"""Snapshot reconstruction: spectra at the open pixels, then a cube on the SLM grid.

1. :func:`measure_samples` extracts the spectrum of every open pixel of one spectral
   frame with :mod:`sassi_bench.spectra`: the streak geometry of the open pixels, the
   background estimated from the camera pixels outside their predicted footprints
   (:func:`~sassi_bench.spectra.offset.estimate_background`), row unmixing and the
   within-streak deblur (:class:`~sassi_bench.spectra.deblur.SpectralDeblur`); divided by
   the exposure, and by the bundle's response when it has one.
2. :func:`rank1_factors` spreads them over the SLM with the guide image by the SASSI
   paper's rank-1 model per region: every pixel of the region of a sample takes the
   region's summed spectra scaled by its own guide intensity over the region's summed guide
   intensity at the measured pixels. It is kept factored
   (:class:`~sassi_bench.snapshot.factored.Rank1Cube`); :func:`rank1_cube` writes the
   dense cube. The masked guided filter is :mod:`sassi_bench.snapshot.guided`.

Dense cubes are ``(H, W, B)`` float32 on the SLM grid at the bundle's bins, in the units
:func:`measure_samples` reports; :func:`snapshot_dataset` and :func:`write_cube` store them
like scan cubes (NetCDF and ENVI, :mod:`sassi_bench.spectra.cube_io`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import (
    check_dtype_kind,
    check_ndim,
    check_shape,
    check_shape_equality,
)
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot.factored import Rank1Cube
from sassi_bench.spectra.crosstalk import columns_interact
from sassi_bench.spectra.cube_io import spectral_cube_dataset, write_envi, write_netcdf
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.extract import (
    DenseModel,
    dense_model,
    extract_spectra,
    extract_with_background,
)
from sassi_bench.spectra.geometry import StreakGeometry, reached_rows, streak_geometry
from sassi_bench.spectra.offset import (
    Background,
    BlockBackground,
    estimate_background,
    streak_footprint,
)

__all__ = [
    "MaskModel",
    "guide_intensity",
    "mask_model",
    "measure_samples",
    "measure_with_background",
    "rank1_cube",
    "rank1_factors",
    "snapshot_dataset",
    "write_cube",
]

#: Units of the spectra without and with a bundle response (as scan cubes).
CAMERA_UNITS = "camera ADU per second per bin"
RADIANCE_UNITS = "relative photon radiance per bin"
#: Background refinements for dense masks: where the agreement of the open pixels' spectra
#: with a scan stops improving on the sim rig, at a few ms a pass (the measurements:
#: docs/notes/2026-11-29-docstring-measurements.md).
DENSE_BACKGROUND_PASSES = 24
#: Background refinements of a dense mask started from the previous video frame's background
#: (:func:`measure_with_background`): one warm pass measures as well as
#: :data:`DENSE_BACKGROUND_PASSES` from scratch on a moving scene
#: (``benchmarks/video_spectra_accuracy.py``). A sudden change of the leakage (a light
#: switched) is caught by the first pass (:data:`~sassi_bench.spectra.extract.JUMP`), which
#: then goes on to :data:`DENSE_BACKGROUND_PASSES`.
WARM_BACKGROUND_PASSES = 1


def _open_pixels(pixels: ArrayLike, shape: tuple[int, int], step: str):
    array = np.asarray(pixels)
    if array.dtype == np.bool_:
        check_shape(
            array,
            tuple(shape),
            step=step,
            name="the mask",
            expected_for="the SLM",
            fix="pass the (H, W) mask shown on the SLM, or (N, 2) (row, column) pixels",
        )
        rows, cols = np.nonzero(array)
        return rows, cols
    fix = "pass a boolean (H, W) mask or an (N, 2) integer array of (row, column)"
    check_shape(array, ("N", 2), step=step, name="the open pixel list", fix=fix)
    check_dtype_kind(array, "iu", step=step, name="the open pixel list", fix=fix)
    rows, cols = array[:, 0].astype(np.intp), array[:, 1].astype(np.intp)
    h, w = shape
    if rows.size and (rows.min() < 0 or cols.min() < 0 or rows.max() >= h or cols.max() >= w):
        raise ProcedureError(
            step_error(step, f"open pixels lie outside the {h} x {w} SLM", "pass SLM pixels")
        )
    return rows, cols


@dataclass(frozen=True)
class MaskModel:
    """What the spectra of a mask's frame need from the mask alone: its open pixels, the
    camera rows they reach, their streak geometry there and, when streaks of different SLM
    columns meet (a dense mask), the factorised streak model
    (:class:`~sassi_bench.spectra.extract.DenseModel`). A video builds the next frame's on
    the segmentation thread as soon as the mask is planned (:func:`mask_model`), so the
    spectra thread starts from the frame.

    Examples
    --------
    Not run here (it needs captured frames)::

        prepared = mask_model(bundle, mask, (2048, 2048))
        spectra, units, bg = measure_with_background(
            frame, mask, bundle, exposure_s=0.05, prepared=prepared)
    """

    rows: NDArray[np.intp]
    cols: NDArray[np.intp]
    camera_shape: tuple[int, int]
    camera_rows: tuple[int, int]
    geometry: StreakGeometry
    dense: DenseModel | None
    block: tuple[int, int]


def mask_model(
    bundle: CalibrationBundle,
    pixels: ArrayLike,
    camera_shape: tuple[int, int],
    *,
    camera_rows: tuple[int, int] | None = None,
    background_block: tuple[int, int] = (8, 16),
) -> MaskModel:
    """The :class:`MaskModel` of the open ``pixels`` (a mask or (N, 2) (row, column)) on a
    camera of ``camera_shape`` (H, W) (``camera_rows``: its :func:`reached_rows`, when
    known), with background blocks of ``background_block``."""
    rows, cols = _open_pixels(pixels, bundle.slm_shape, "snapshot spectra")
    height, width = (int(v) for v in camera_shape)
    top, bottom = camera_rows if camera_rows else reached_rows(bundle, height)
    geometry = streak_geometry(bundle, rows, cols).shifted(top)
    block = (int(background_block[0]), int(background_block[1]))
    dense = None
    if rows.size and columns_interact(geometry):
        dense = dense_model(geometry, (bottom - top, width), block)
    return MaskModel(rows, cols, (height, width), (int(top), int(bottom)), geometry, dense, block)


def measure_samples(
    frame: ArrayLike,
    pixels: ArrayLike,
    bundle: CalibrationBundle,
    *,
    exposure_s: float,
    deblur: SpectralDeblur | None = None,
    full_scale: float = 65535.0,
    background_block: tuple[int, int] = (8, 16),
    background_passes: int | None = None,
    closed: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], str]:
    """Spectra of the open SLM pixels of one spectral frame, offset removed.

    Parameters
    ----------
    frame
        The raw spectral frame (camera rows, columns), dark level and background included.
    pixels
        The mask shown (``(H, W)`` bool; spectra in row-major order, as ``np.nonzero``) or
        ``(N, 2)`` (row, column) of the open pixels (spectra in that order).
    bundle
        The calibration bundle.
    exposure_s
        The frame's exposure (``frame.meta.exposure_s``); spectra are per second.
    deblur
        The within-streak unmixing; built from the bundle when None (pass one to
        reconstruct many frames, and it is built once).
    full_scale
        The camera's full-scale reading (the deblur's reference signal level).
    background_block
        Camera (rows, columns) of the blocks whose medians outside the footprints give the
        background (:func:`~sassi_bench.spectra.offset.estimate_background`). Larger
        blocks follow the closed pixels' leakage, which
        carries the scene's vertical structure, less closely.
    background_passes
        Refinements of the background from the residual of the unmixed streaks
        (:func:`~sassi_bench.spectra.extract.extract_with_background`); None:
        :data:`DENSE_BACKGROUND_PASSES` when streaks of different SLM columns overlap (a
        dense mask leaves too few pixels outside the footprints), else none. Streaks of
        different columns are always unmixed jointly where they overlap.
    closed
        A raw frame of the closed SLM (all pixels closed) of the same scene, light and
        exposure: it is the background, pixel by pixel, in place of the estimate. The
        closed pixels' leak is the scene dispersed and can vary faster than the estimate's
        blocks follow; where the open pixels' footprints cover most of the frame (wide
        spots, a dense mask) the estimate then misses leak under them, and a closed frame
        measures it (the measurements: docs/notes/2026-11-30-singlet-snapshot-spectra.md).

    Returns
    -------
    spectra : ndarray
        (N, B) float64 at ``bundle.wavelengths``.
    units : str
        ``"relative photon radiance per bin"`` when the bundle has a response (the spectra
        are divided by it), else ``"camera ADU per second per bin"``.

    Examples
    --------
    Not run here (it needs captured frames)::

        frame = rig.spectral_camera.capture()
        spectra, units = measure_samples(frame.data, mask, bundle,
                                         exposure_s=frame.meta.exposure_s)
    """
    spectra, units, _ = measure_with_background(
        frame, pixels, bundle, exposure_s=exposure_s, deblur=deblur, full_scale=full_scale,
        background_block=background_block, background_passes=background_passes, closed=closed,
    )  # fmt: skip
    return spectra, units


def measure_with_background(
    frame: ArrayLike,
    pixels: ArrayLike,
    bundle: CalibrationBundle,
    *,
    exposure_s: float,
    deblur: SpectralDeblur | None = None,
    full_scale: float = 65535.0,
    background_block: tuple[int, int] = (8, 16),
    background_passes: int | None = None,
    background_start: BlockBackground | NDArray[np.floating] | None = None,
    prepared: MaskModel | None = None,
    closed: ArrayLike | None = None,
) -> tuple[NDArray[np.float64], str, Background | BlockBackground]:
    """:func:`measure_samples`, also returning the background it removed, and starting its
    refinements from ``background_start`` when given (video: the previous frame's
    background, so a few passes follow a slowly changing scene).

    Parameters
    ----------
    frame, pixels, bundle, exposure_s, deblur, full_scale, background_block, background_passes
        As :func:`measure_samples`.
    closed
        As :func:`measure_samples`: the background is this frame (the returned
        background is its :class:`~sassi_bench.spectra.offset.Background`, blocks unused).
    background_start
        The background of the reached camera rows to refine when the mask is dense (a
        returned :class:`~sassi_bench.spectra.offset.BlockBackground`, or an image), by
        :data:`WARM_BACKGROUND_PASSES` passes unless ``background_passes`` says; None:
        estimated from the pixels outside the footprints.
    prepared
        The :func:`mask_model` of ``pixels`` on this camera, built before the frame
        (video); None: built here.

    Returns
    -------
    spectra : ndarray
        (N, B) float64 at ``bundle.wavelengths``.
    units : str
        As :func:`measure_samples`.
    background : Background or BlockBackground
        The background of the reached camera rows (a
        :class:`~sassi_bench.spectra.offset.BlockBackground` when the mask is dense).

    Examples
    --------
    Not run here (it needs captured frames)::

        spectra, units, background = measure_with_background(
            frame.data, mask, bundle, exposure_s=0.05)
        spectra, units, background = measure_with_background(
            next_frame.data, next_mask, bundle, exposure_s=0.05, background_passes=2,
            background_start=background)
    """
    step = "snapshot spectra"
    image = np.asarray(frame)
    check_ndim(image, 2, step=step, name="the frame", fix="pass one spectral-camera frame")
    check_dtype_kind(
        image, "iuf", step=step, name="the frame", fix="pass one spectral-camera frame"
    )
    if not (np.isfinite(exposure_s) and exposure_s > 0):
        raise ProcedureError(step_error(step, f"exposure_s is {exposure_s}", "pass seconds > 0"))
    if deblur is None:
        deblur = SpectralDeblur.from_bundle(bundle, full_scale=full_scale)
    if prepared is None:
        prepared = mask_model(bundle, pixels, image.shape, background_block=background_block)
    elif prepared.camera_shape != image.shape or prepared.block != tuple(background_block):
        raise ProcedureError(
            step_error(
                step,
                f"the mask's model was prepared for a {prepared.camera_shape} camera in "
                f"{prepared.block} blocks, the frame is {image.shape} in {background_block}",
                "prepare it with the camera's frame shape and the same blocks",
            )
        )
    # Only the camera rows that light of the SLM can reach take part.
    top, bottom = prepared.camera_rows
    window = image[top:bottom]
    geometry = prepared.geometry
    if background_passes is None and prepared.dense is not None:
        warm = background_start is not None
        background_passes = WARM_BACKGROUND_PASSES if warm else DENSE_BACKGROUND_PASSES
    if isinstance(background_start, Background):
        background_start = background_start.image
    if closed is not None:
        background = _closed_background(closed, image.shape, top, bottom, step)
        light = window - background.image
        if prepared.dense is not None:
            # The open pixels' light alone: unmixed across columns with no background left.
            spectra, _, _ = extract_with_background(
                light, geometry, deblur, block=background_block, passes=0,
                start=np.zeros(light.shape), prepared=prepared.dense,
            )  # fmt: skip
        else:
            spectra, _ = extract_spectra(light, geometry, deblur)
    elif background_passes:
        spectra, _, background = extract_with_background(
            window, geometry, deblur, block=background_block, passes=background_passes,
            start=background_start, settle=DENSE_BACKGROUND_PASSES, prepared=prepared.dense,
        )  # fmt: skip
    else:
        background = estimate_background(
            window, streak_footprint(geometry, window.shape), block=background_block
        )
        spectra, _ = extract_spectra(window - background.image, geometry, deblur)
    spectra /= exposure_s
    if bundle.response is not None:
        return spectra / np.asarray(bundle.response), RADIANCE_UNITS, background
    return spectra, CAMERA_UNITS, background


def _closed_background(
    closed: ArrayLike, shape: tuple[int, ...], top: int, bottom: int, step: str
) -> Background:
    """The closed-SLM frame's reached rows as the background (float64)."""
    image = np.asarray(closed)
    fix = "pass a spectral-camera frame of the closed SLM at the snapshot's exposure"
    check_dtype_kind(image, "iuf", step=step, name="the closed-SLM frame", fix=fix)
    check_shape(
        image, tuple(shape), step=step, name="the closed-SLM frame",
        expected_for="the snapshot frame", fix=fix,
    )  # fmt: skip
    # Measured at every pixel: no fit residual, every pixel free.
    return Background(np.asarray(image[top:bottom], dtype=np.float64), 0.0, 1.0)


def guide_intensity(guide_slm: ArrayLike) -> NDArray[np.float32]:
    """The guide's intensity on the SLM grid: the sum of its channels, (H, W) float32.

    Examples
    --------
    >>> guide_intensity(np.ones((2, 3, 3))).tolist()[0]
    [3.0, 3.0, 3.0]
    """
    array = np.asarray(guide_slm, dtype=np.float32)
    if array.ndim != 3:
        return array
    # Channel by channel: numpy's reduction over a short last axis is slower, and the
    # sum is the same (left to right, float32).
    total = array[..., 0].copy()
    for channel in range(1, array.shape[2]):
        total += array[..., channel]
    return total


def _check_samples(guide, rows, cols, spectra, step):
    check_ndim(guide, (2, 3), step=step, name="the guide", fix="pass (H, W[, C])")
    intensity = guide_intensity(guide)
    values = np.asarray(spectra)
    if values.ndim != 2 or values.shape[0] != rows.size or rows.size == 0:
        raise ProcedureError(
            step_error(
                step,
                f"{rows.size} open pixels but spectra of shape {values.shape}",
                "pass one spectrum per open pixel, in the order of the pixels",
            )
        )
    return intensity, values


def rank1_factors(
    guide_slm: ArrayLike,
    labels: ArrayLike,
    pixels: ArrayLike,
    spectra: ArrayLike,
) -> Rank1Cube:
    """Rank-1 reconstruction per region (the SASSI paper's model), in factored form.

    For region ``r`` with measured pixels ``j``: ``cube[p] = I[p] / sum_j I[j] * sum_j s_j``
    for every pixel ``p`` of the region (``I`` the guide intensity, ``s_j`` the measured
    spectra). A region whose measured pixels have no guide intensity takes their mean
    spectrum; a region without measured pixels is zero. The result keeps the labels, the
    per-pixel scale and one spectrum per region (exact); :meth:`Rank1Cube.dense` writes the
    cube.

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, C) guide image on the SLM grid (intensity = sum of channels; an
        (H, W) float32 intensity is kept as the cube's scale, not copied).
    labels
        (H, W) int region of every SLM pixel (e.g. :attr:`AdaptiveMask.labels`; intp
        labels are kept, not copied).
    pixels
        The mask or (N, 2) (row, column) of the measured pixels, as given to
        :func:`measure_samples`.
    spectra
        (N, B) measured spectra.

    Returns
    -------
    Rank1Cube

    Examples
    --------
    >>> guide = np.array([[1.0, 2.0, 4.0]]); labels = np.array([[0, 0, 1]])
    >>> cube = rank1_factors(guide, labels, np.array([[0, 0], [0, 2]]), [[10.0], [8.0]])
    >>> cube.spectra[:, 0].tolist(), cube.band(0).tolist()
    ([10.0, 2.0], [[10.0, 20.0, 8.0]])
    """
    regions = np.asarray(labels)
    step = "snapshot rank-1 reconstruction"
    rows, cols = _open_pixels(pixels, regions.shape, step)
    intensity, values = _check_samples(guide_slm, rows, cols, spectra, step)
    check_shape_equality(
        intensity,
        regions,
        step=step,
        names=("the guide", "the labels"),
        fix="pass the guide image and labels on the same SLM grid",
    )
    n_regions = int(regions.max()) + 1
    owner = regions[rows, cols]
    weight = intensity[rows, cols].astype(np.float64)
    summed_intensity = np.bincount(owner, weight, n_regions)
    counts = np.bincount(owner, minlength=n_regions)
    summed = np.zeros((n_regions, values.shape[1]))
    np.add.at(summed, owner, values)
    ratio = np.zeros_like(summed)
    bright = summed_intensity > 0
    ratio[bright] = summed[bright] / summed_intensity[bright, None]
    # Regions without guide light: the mean spectrum, flat over the region.
    dark = ~bright & (counts > 0)
    ratio[dark] = summed[dark] / counts[dark, None]
    regions = np.ascontiguousarray(regions, np.intp)
    scale = np.ascontiguousarray(intensity, np.float32)  # shared with an (H, W) guide passed in
    if dark.any():
        scale = np.where(dark[regions], np.float32(1.0), scale)
    return Rank1Cube(regions, scale, ratio.astype(np.float32))


def rank1_cube(
    guide_slm: ArrayLike,
    labels: ArrayLike,
    pixels: ArrayLike,
    spectra: ArrayLike,
    *,
    out: NDArray[np.float32] | None = None,
) -> NDArray[np.float32]:
    """Rank-1 reconstruction per region as a dense cube (:func:`rank1_factors` materialised).

    Parameters
    ----------
    guide_slm, labels, pixels, spectra
        As :func:`rank1_factors`.
    out
        A C-contiguous (H, W, B) float32 array to write into (video: reusing one saves
        touching fresh memory, which is most of the time at the prototype scale).

    Returns
    -------
    ndarray
        (H, W, B) float32.

    Examples
    --------
    >>> guide = np.array([[1.0, 2.0, 4.0]]); labels = np.array([[0, 0, 1]])
    >>> rank1_cube(guide, labels, np.array([[0, 0], [0, 2]]), [[10.0], [8.0]])[0, :, 0].tolist()
    [10.0, 20.0, 8.0]
    """
    return rank1_factors(guide_slm, labels, pixels, spectra).dense(out)


def snapshot_dataset(
    cube: NDArray[np.floating],
    bundle: CalibrationBundle,
    *,
    units: str,
    method: str,
    exposure_s: float | None = None,
    attrs: dict[str, Any] | None = None,
) -> xr.Dataset:
    """A reconstructed cube as an xarray Dataset like a scan cube's, with provenance: the
    bundle's response when the cube was divided by it (``units`` is
    :data:`RADIANCE_UNITS`) and the frame's exposure.

    Examples
    --------
    Not run here (it needs captured frames)::

        ds = snapshot_dataset(cube, bundle, units=units, method="rank-1")
        ds["radiance"].dims
        # ('y', 'x', 'wavelength')
    """
    h, w = bundle.slm_shape
    check_shape(
        cube,
        (h, w, bundle.wavelengths.size),
        step="snapshot cube",
        name="the cube",
        expected_for="the bundle's SLM and bins",
        fix="reconstruct with this bundle",
    )
    return spectral_cube_dataset(
        cube.astype(np.float32, copy=False),
        bundle.wavelengths,
        bundle.bin_edges,
        units=units,
        response=bundle.response if units == RADIANCE_UNITS else None,
        exposure_s=exposure_s,
        title=f"SASSI snapshot ({method})",
        attrs={
            "bundle_version": bundle.version,
            "bundle_rig": bundle.rig_name,
            "reconstruction": method,
            **(attrs or {}),
        },
    )


def write_cube(
    ds: xr.Dataset,
    path: str | os.PathLike[str],
    *,
    envi: str | os.PathLike[str] | None = None,
    overwrite: bool = False,
) -> list[Path]:
    """Write a cube Dataset to NetCDF (and ENVI when ``envi`` names a file), never over an
    existing file unless ``overwrite``; returns the paths written.

    Examples
    --------
    Not run here (it needs captured frames)::

        write_cube(ds, "snapshot.nc", envi="snapshot")
        # [PosixPath('snapshot.nc'), PosixPath('snapshot.hdr')]
    """
    written = [write_netcdf(ds, path, overwrite=overwrite)]
    if envi is not None:
        written.append(write_envi(ds, envi, overwrite=overwrite))
    return written
