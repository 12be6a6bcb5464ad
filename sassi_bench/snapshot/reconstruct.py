"""Snapshot reconstruction: spectra at the open pixels, then a cube on the SLM grid.

1. :func:`measure_samples` extracts the spectrum of every open pixel of one spectral
   frame with :mod:`sassi_bench.spectra`: the streak geometry of the open pixels, the
   background estimated from the camera pixels outside their predicted footprints
   (:func:`~sassi_bench.spectra.offset.estimate_background`), row unmixing and the
   within-streak deblur (:class:`~sassi_bench.spectra.deblur.SpectralDeblur`); divided by
   the exposure, and by the bundle's response when it has one.
2. The spectra are spread over the SLM with the guide image:

   * :func:`rank1_cube`: the SASSI paper's rank-1 model per region. Every pixel of the
     region of a sample takes the region's summed spectra scaled by its own guide intensity
     over the region's summed guide intensity at the measured pixels.
   * :func:`guided_cube`: a masked guided filter per band, the weighted least-squares form:
     in every window a band is fitted as ``a I + b`` of the guide intensity over the measured
     pixels only (weight 1 at measured pixels, 0 elsewhere; ridge ``eps`` on ``a``), and a
     pixel's output averages the fits of the windows that hold it, each weighted by its
     number of measured pixels. It averages several measured pixels per window, so it
     suppresses noise that rank-1 (one region's few pixels) keeps.

Both return ``(H, W, B)`` float32 cubes on the SLM grid at the bundle's bins, in the units
:func:`measure_samples` reports; :func:`snapshot_dataset` and :func:`write_cube` store them
like scan cubes (NetCDF and ENVI, :mod:`sassi_bench.spectra.cube_io`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import cv2
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
from sassi_bench.snapshot import _kernels
from sassi_bench.spectra.crosstalk import columns_interact
from sassi_bench.spectra.cube_io import spectral_cube_dataset, write_envi, write_netcdf
from sassi_bench.spectra.deblur import SpectralDeblur
from sassi_bench.spectra.extract import extract_spectra, extract_with_background
from sassi_bench.spectra.geometry import reached_rows, streak_geometry
from sassi_bench.spectra.offset import estimate_background, streak_footprint

__all__ = [
    "guide_intensity",
    "guided_cube",
    "measure_samples",
    "rank1_cube",
    "snapshot_dataset",
    "write_cube",
]

#: Units of the spectra without and with a bundle response (as scan cubes).
CAMERA_UNITS = "camera ADU per second per bin"
RADIANCE_UNITS = "relative photon radiance per bin"
#: Background refinements for dense masks. On the sim rig (natural scene, LED, adaptive mask
#: at a 6 px row pitch, 380 open pixels) the spectra at the open pixels agreed with the scan
#: to 22.3 dB after none, 34.5 after 2, 40.2 after 8, 42.0 after 24 and 42.1 after 32; at a
#: 5 px pitch 41.1 after 24. Each pass costs about 15 ms there (the streak model is
#: factorised once), so the frame takes about 0.4 s.
DENSE_BACKGROUND_PASSES = 24


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
        The within-streak unmixing; built from the bundle when None (about 0.1 s: pass one
        to reconstruct many frames).
    full_scale
        The camera's full-scale reading (the deblur's reference signal level).
    background_block
        Camera (rows, columns) of the blocks whose medians outside the footprints give the
        background (:func:`~sassi_bench.spectra.offset.estimate_background`; about 20 ms
        on a 2048 x 2048 frame). Larger blocks follow the closed pixels' leakage, which
        carries the scene's vertical structure, less closely.
    background_passes
        Refinements of the background from the residual of the unmixed streaks
        (:func:`~sassi_bench.spectra.extract.extract_with_background`); None:
        :data:`DENSE_BACKGROUND_PASSES` when streaks of different SLM columns overlap (a
        dense mask leaves too few pixels outside the footprints), else none. Streaks of
        different columns are always unmixed jointly where they overlap.

    Returns
    -------
    spectra : ndarray
        (N, B) float64 at ``bundle.wavelengths``.
    units : str
        ``"relative photon radiance per bin"`` when the bundle has a response (the spectra
        are divided by it), else ``"camera ADU per second per bin"``.

    Examples
    --------
    >>> frame = rig.spectral_camera.capture()  # doctest: +SKIP
    >>> spectra, units = measure_samples(frame.data, mask, bundle,
    ...                                  exposure_s=frame.meta.exposure_s)  # doctest: +SKIP
    """
    step = "snapshot spectra"
    image = np.asarray(frame)
    check_ndim(image, 2, step=step, name="the frame", fix="pass one spectral-camera frame")
    check_dtype_kind(
        image, "iuf", step=step, name="the frame", fix="pass one spectral-camera frame"
    )
    if not (np.isfinite(exposure_s) and exposure_s > 0):
        raise ProcedureError(step_error(step, f"exposure_s is {exposure_s}", "pass seconds > 0"))
    rows, cols = _open_pixels(pixels, bundle.slm_shape, step)
    if deblur is None:
        deblur = SpectralDeblur.from_bundle(bundle, full_scale=full_scale)
    # Only the camera rows that light of the SLM can reach take part.
    top, bottom = reached_rows(bundle, image.shape[0])
    window = image[top:bottom]
    geometry = streak_geometry(bundle, rows, cols).shifted(top)
    if background_passes is None:
        background_passes = DENSE_BACKGROUND_PASSES if columns_interact(geometry) else 0
    if background_passes:
        spectra, _, _ = extract_with_background(
            window, geometry, deblur, block=background_block, passes=background_passes
        )
    else:
        background = estimate_background(
            window, streak_footprint(geometry, window.shape), block=background_block
        )
        spectra, _ = extract_spectra(window - background.image, geometry, deblur)
    spectra /= exposure_s
    if bundle.response is not None:
        return spectra / np.asarray(bundle.response), RADIANCE_UNITS
    return spectra, CAMERA_UNITS


def guide_intensity(guide_slm: ArrayLike) -> NDArray[np.float32]:
    """The guide's intensity on the SLM grid: the sum of its channels, (H, W) float32.

    Examples
    --------
    >>> guide_intensity(np.ones((2, 3, 3))).tolist()[0]
    [3.0, 3.0, 3.0]
    """
    array = np.asarray(guide_slm, dtype=np.float32)
    return array.sum(axis=2, dtype=np.float32) if array.ndim == 3 else array


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


def rank1_cube(
    guide_slm: ArrayLike,
    labels: ArrayLike,
    pixels: ArrayLike,
    spectra: ArrayLike,
    *,
    out: NDArray[np.float32] | None = None,
) -> NDArray[np.float32]:
    """Rank-1 reconstruction per region (the SASSI paper's model).

    For region ``r`` with measured pixels ``j``: ``cube[p] = I[p] / sum_j I[j] * sum_j s_j``
    for every pixel ``p`` of the region (``I`` the guide intensity, ``s_j`` the measured
    spectra). A region whose measured pixels have no guide intensity takes their mean
    spectrum; a region without measured pixels is zero.

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, C) guide image on the SLM grid (intensity = sum of channels).
    labels
        (H, W) int region of every SLM pixel (e.g. :attr:`AdaptiveMask.labels`).
    pixels
        The mask or (N, 2) (row, column) of the measured pixels, as given to
        :func:`measure_samples`.
    spectra
        (N, B) measured spectra.
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
    flat = np.zeros(n_regions, bool)
    flat[dark] = True
    ratio[dark] = summed[dark] / counts[dark, None]
    scale = np.where(flat[regions], np.float32(1.0), intensity).astype(np.float32)
    shape = (*regions.shape, values.shape[1])
    if out is None:
        cube = np.empty(shape, np.float32)
    elif out.shape != shape or out.dtype != np.float32 or not out.flags.c_contiguous:
        raise ProcedureError(
            step_error(
                step,
                f"out has shape {out.shape} and dtype {out.dtype}",
                f"pass a C-contiguous float32 array of shape {shape}",
            )
        )
    else:
        cube = out
    _kernels.spread_regions(
        ratio.astype(np.float32), np.ascontiguousarray(regions, np.intp), scale, cube
    )
    return cube


def guided_cube(
    guide_slm: ArrayLike,
    pixels: ArrayLike,
    spectra: ArrayLike,
    *,
    radius: int | None = None,
    eps: float = 1e-3,
) -> NDArray[np.float32]:
    """Masked guided filter per band (weighted least squares on the guide intensity).

    In every ``(2 radius + 1)^2`` box window ``k``, each band ``P`` is fitted over the
    measured pixels only as ``P = a_k I + b_k`` (``I`` the guide intensity divided by its
    maximum), minimising ``sum_j (a_k I_j + b_k - P_j)^2 + n_k eps a_k^2`` (``n_k`` the
    measured pixels in the window). The output at a pixel is
    ``sum_k n_k (a_k I + b_k) / sum_k n_k`` over the windows holding it. Box sums come from
    ``cv2.boxFilter``, four bands a pass; the loop is over bands, never pixels.

    Parameters
    ----------
    guide_slm
        (H, W) or (H, W, C) guide image on the SLM grid.
    pixels
        The mask or (N, 2) (row, column) of the measured pixels.
    spectra
        (N, B) measured spectra.
    radius
        Window radius in SLM px; default ``1.5 sqrt(H W / N)`` (about nine measured pixels
        a window).
    eps
        Ridge on the slope, in units of the normalised guide's variance: larger values
        flatten the fit towards the window's mean.

    Returns
    -------
    ndarray
        (H, W, B) float32.

    Examples
    --------
    >>> guide = np.tile(np.arange(1.0, 9.0), (6, 1))  # a ramp
    >>> pixels = np.array([[1, 1], [4, 6], [2, 3]])
    >>> spectra = 5.0 * guide[pixels[:, 0], pixels[:, 1], None] / 8 + 1.0  # affine in it
    >>> cube = guided_cube(guide, pixels, spectra, radius=8, eps=1e-9)
    >>> bool(np.allclose(cube[..., 0], 5.0 * guide / 8 + 1.0, atol=1e-4))
    True
    """
    intensity = guide_intensity(guide_slm)
    step = "snapshot guided filter"
    rows, cols = _open_pixels(pixels, intensity.shape, step)
    intensity, values = _check_samples(guide_slm, rows, cols, spectra, step)
    if not (np.isfinite(eps) and eps >= 0):
        raise ProcedureError(step_error(step, f"eps is {eps}", "pass a number >= 0"))
    h, w = intensity.shape
    peak = float(intensity.max())
    guide = intensity / peak if peak > 0 else intensity
    if radius is None:
        radius = round(1.5 * float(np.sqrt(h * w / rows.size)))
    size = (2 * int(radius) + 1,) * 2

    def box(image):
        return cv2.boxFilter(image, cv2.CV_32F, size, normalize=True, borderType=cv2.BORDER_REFLECT)

    weight = np.zeros((h, w), np.float32)
    weight[rows, cols] = 1.0
    g_at = guide[rows, cols]
    n = box(weight)
    present = n > 0.5 / (size[0] * size[1])  # at least one measured pixel in the window
    safe = np.where(present, n, 1.0)
    sparse = np.zeros((h, w), np.float32)
    sparse[rows, cols] = g_at
    mean_i = box(sparse) / safe
    sparse[rows, cols] = g_at * g_at
    var_i = np.maximum(box(sparse) / safe - mean_i * mean_i, 0.0)
    denominator = var_i + np.float32(eps)
    norm = box(n)
    norm_safe = np.where(norm > 0, norm, 1.0)
    cube = np.empty((h, w, values.shape[1]), np.float32)
    mean_i = mean_i.astype(np.float32)
    denominator = denominator.astype(np.float32)
    n = n.astype(np.float32)
    guide = guide.astype(np.float32)
    norm_safe = norm_safe.astype(np.float32)
    # Four bands at a time (OpenCV filters up to four channels in one pass); the arithmetic
    # between the filters is compiled (numpy's temporaries took three quarters of the time).
    sparse = np.zeros((h, w, 4), np.float32)
    a, b = np.empty((h, w, 4), np.float32), np.empty((h, w, 4), np.float32)
    for start in range(0, values.shape[1], 4):
        chunk = values[:, start : start + 4].astype(np.float32)
        k = chunk.shape[1]
        sparse[rows, cols, :k] = chunk
        mean_p = box(np.ascontiguousarray(sparse[..., :k])).reshape(h, w, k) / safe[..., None]
        sparse[rows, cols, :k] = chunk * g_at[:, None]
        mean_pi = box(np.ascontiguousarray(sparse[..., :k])).reshape(h, w, k) / safe[..., None]
        a_k, b_k = np.ascontiguousarray(a[..., :k]), np.ascontiguousarray(b[..., :k])
        _kernels.weighted_lines(
            mean_p.astype(np.float32), mean_pi.astype(np.float32), n, mean_i, denominator,
            present, a_k, b_k,
        )  # fmt: skip
        _kernels.apply_lines(
            box(a_k).reshape(h, w, k), box(b_k).reshape(h, w, k), guide, norm_safe, cube, start
        )
    return cube


def snapshot_dataset(
    cube: NDArray[np.floating],
    bundle: CalibrationBundle,
    *,
    units: str,
    method: str,
    attrs: dict[str, Any] | None = None,
) -> xr.Dataset:
    """A reconstructed cube as an xarray Dataset like a scan cube's, with provenance.

    Examples
    --------
    >>> ds = snapshot_dataset(cube, bundle, units=units, method="rank-1")  # doctest: +SKIP
    >>> ds["radiance"].dims  # doctest: +SKIP
    ('y', 'x', 'wavelength')
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
    >>> write_cube(ds, "snapshot.nc", envi="snapshot")  # doctest: +SKIP
    [PosixPath('snapshot.nc'), PosixPath('snapshot.hdr')]
    """
    written = [write_netcdf(ds, path, overwrite=overwrite)]
    if envi is not None:
        written.append(write_envi(ds, envi, overwrite=overwrite))
    return written
