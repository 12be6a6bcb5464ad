"""Calibration files for the SASSI authors' reconstruction code (``sassi-mat`` export).

The reconstruction code published with the SASSI paper (Image-Science-Lab-cmu/SASSI on
GitHub, ``modules/cassi.py``, MIT licence) reads its calibration from two MATLAB files.
:func:`export_sassi_mat` writes them from a bundle, with a ``README.txt`` beside them.
What the files must hold was worked out from how that code uses them (the functions
are named as in ``cassi.py``):

``calibstack.mat``
    ``calibstack_row``, ``calibstack_col``: camera-sized ``(Hc, Wc, T)`` arrays, for each
    spectral-camera pixel and band the SLM row and column whose light of that band lands
    on the pixel's centre, **1-based** (``__main__`` subtracts 1). ``get_cassi_img``
    passes them to ``torch.nn.functional.grid_sample`` as the sampling grid of a float32
    cube, and ``grid_sample`` requires grid and input of one dtype: they are **float32**
    (float64 raises). It normalises ``c`` (0-based) as ``(2 c - H) / H`` with
    ``align_corners=False``, which reads the SLM at ``c - 0.5``: the streak image it
    builds sits half an SLM pixel up and left of the true one. That image only picks
    the streak-free pixels from which ``get_offset`` estimates the background, so the
    export stores the true positions and leaves that quirk alone.
    Camera pixels no SLM pixel reaches hold **0**: after the code's ``- 1`` that is
    ``-1``, which ``grid_sample`` (zero padding) reads as 0, so the pixel counts as
    streak-free, as it is. NaN must not be used: ``grid_sample`` is documented to
    mishandle NaN grids (PyTorch issue 24823: wrong values, a segfault in the CPU
    kernel), and a NaN would spread through the blur ``conv2d`` and remove its
    neighbours from the offset estimate.
    ``wavelengths``: ``(T,)`` band centres in nm (``hyper2rgb`` maps them to colours;
    ``T`` sets the length of the hard-coded blur list ``ksizes``).

``reverse_lookup.mat``
    ``Xl``, ``Yl``: SLM-sized ``(Hl, Wl, T)`` arrays of camera coordinates of every SLM
    pixel per band, **1-based** (``__main__`` subtracts 1 after ``astype(float32)``).
    ``get_cassi_cube`` calls ``_get_cassi_cube(cassi_img2, mask, Yl, Xl, ...)`` with the
    two **swapped**, and ``_get_cassi_cube`` calls ``cv2.remap(img, Xl, Yl, ...)``: the
    file's ``Yl`` becomes remap's first (x, column) map and ``Xl`` its second (y, row).
    So, whatever the names suggest, **Xl holds the camera row and Yl the camera
    column**. (The disabled ``if False:`` branch of ``__main__`` swaps them again; it
    never runs.) SLM pixels whose light leaves the camera keep their (outside)
    coordinates, which ``cv2.remap``'s constant border reads as 0. ``Hl, Wl`` must be the
    shape of ``lcos_mask`` (``get_cassi_img`` fills its cube with the mask).

Blur: ``__main__`` hard-codes ``ksizes = linspace(1, 4, T)**2 / 4``, used only by
``get_cassi_img`` (``filtering.gaussdiskwin``: a window of ``2 ceil(k - 0.5) + 1``
pixels) to widen the streak mask. ``calibstack.mat`` adds ``blur_sigma_px`` (the
bundle's blur per band) and ``ksizes`` whose windows reach 3 sigma, for whoever wants
to replace that line; the code ignores variables it does not read.

Each capture (``adaptive_cassi.mat``) is written by :mod:`sassi_bench.export.adaptive_cassi`.

Examples
--------
>>> from sassi_bench.bundle import load
>>> result = export_sassi_mat(load(rig="sim"), "for_sassi/")  # doctest: +SKIP
>>> sorted(p.name for p in result.files)  # doctest: +SKIP
['README.txt', 'calibstack.mat', 'reverse_lookup.mat']
"""

from __future__ import annotations

import os
import textwrap
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray
from tqdm.auto import tqdm

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.integrity import MANIFEST_NAME, sha256_file
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.export.camera_lookup import CameraLookup, solve_camera_lookup
from sassi_bench.export.matfile import BandStream, write_mat

__all__ = [
    "CALIBSTACK_FILE",
    "README_FILE",
    "REVERSE_LOOKUP_FILE",
    "SassiMatExport",
    "camera_shape_of",
    "export_sassi_mat",
    "suggested_ksizes",
]

CALIBSTACK_FILE = "calibstack.mat"
REVERSE_LOOKUP_FILE = "reverse_lookup.mat"
README_FILE = "README.txt"
#: SLM rows evaluated per call while building ``Xl``/``Yl`` (bounds the temporaries).
_ROWS_PER_CHUNK = 32


@dataclass(frozen=True)
class SassiMatExport:
    """What :func:`export_sassi_mat` wrote.

    Attributes
    ----------
    folder
        The output folder.
    files
        ``calibstack.mat``, ``reverse_lookup.mat`` and ``README.txt``.
    wavelengths
        The exported bands (nm).
    camera_shape, slm_shape
        ``(Hc, Wc)`` and ``(Hl, Wl)``.
    unreached_fraction
        Per band, the share of camera pixels no SLM pixel reaches (stored as 0).
    seconds
        Wall time of the export.
    """

    folder: Path
    files: tuple[Path, ...]
    wavelengths: NDArray[np.float64]
    camera_shape: tuple[int, int]
    slm_shape: tuple[int, int]
    unreached_fraction: NDArray[np.float64]
    seconds: float

    @property
    def sizes(self) -> dict[str, int]:
        """File name -> size in bytes."""
        return {p.name: p.stat().st_size for p in self.files}


def camera_shape_of(bundle: CalibrationBundle) -> tuple[int, int]:
    """Spectral camera ``(H, W)`` from the rig description stored in the bundle.

    Examples
    --------
    >>> camera_shape_of(load(rig="sim"))  # doctest: +SKIP
    (512, 800)
    """
    camera = bundle.manifest.get("rig", {}).get("spectral_camera", {})
    try:
        return int(camera["height"]), int(camera["width"])
    except (KeyError, TypeError, ValueError):
        raise ProcedureError(
            step_error(
                "sassi-mat export",
                f"the rig description in bundle {bundle.rig_name}/{bundle.version} has no "
                "spectral_camera width and height",
                "pass camera_shape=(height, width) of the spectral camera",
            )
        ) from None


def suggested_ksizes(sigma_px: ArrayLike) -> NDArray[np.float64]:
    """Values for the authors' ``ksizes`` whose ``gaussdiskwin`` windows reach 3 sigma.

    ``gaussdiskwin(k)`` spans ``2 ceil(k - 0.5) + 1`` pixels, so ``k = ceil(3 sigma) + 0.5``
    gives a half-width of ``ceil(3 sigma)``.

    Examples
    --------
    >>> suggested_ksizes([0.4, 1.7]).tolist()
    [2.5, 6.5]
    """
    return np.ceil(3.0 * np.asarray(sigma_px, dtype=np.float64)) + 0.5


def _bands(wavelengths: ArrayLike | None, bundle: CalibrationBundle) -> NDArray[np.float64]:
    lam = np.asarray(bundle.wavelengths if wavelengths is None else wavelengths, float)
    lam = np.atleast_1d(lam)
    edges = bundle.bin_edges
    if lam.ndim != 1 or lam.size == 0 or not np.all(np.isfinite(lam)):
        raise ProcedureError(
            step_error("sassi-mat export", f"bands {lam} are not a list of nm", "pass nm values")
        )
    outside = lam[(lam < edges[0]) | (lam > edges[-1])]
    if outside.size:
        raise ProcedureError(
            step_error(
                "sassi-mat export",
                f"bands {outside.tolist()} nm lie outside the bundle's calibrated range "
                f"{edges[0]:.1f}-{edges[-1]:.1f} nm",
                "choose bands inside that range (the default is the bundle's bin centres)",
            )
        )
    if np.any(np.diff(lam) <= 0):
        raise ProcedureError(
            step_error("sassi-mat export", "bands are not increasing", "sort them, no repeats")
        )
    return lam


def _calibstack_planes(
    lookup: CameraLookup, axis: str, bar: tqdm, unreached: NDArray[np.float64] | None = None
) -> Iterator[NDArray[np.float32]]:
    """1-based SLM row (``axis="v"``) or column (``"u"``) per camera pixel, band by band;
    0 where unreached."""
    for t in range(lookup.wavelengths.size):
        u, v = lookup.band(t)
        plane = v if axis == "v" else u
        missing = np.isnan(plane)
        if unreached is not None:
            unreached[t] = missing.mean()
        plane += 1.0
        plane[missing] = 0.0
        bar.update()
        yield plane


def _reverse_lookup(
    bundle: CalibrationBundle, lam: NDArray[np.float64], bar: tqdm
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """1-based camera row and column of every SLM pixel per band, band-major ``(T, W, H)``
    (the column-major order of an ``(H, W, T)`` MATLAB array)."""
    height, width = bundle.slm_shape
    rows_out = np.empty((lam.size, width, height), dtype=np.float32)
    cols_out = np.empty_like(rows_out)
    u = np.arange(width, dtype=np.float64)[None, :, None]
    for top in range(0, height, _ROWS_PER_CHUNK):
        v = np.arange(top, min(top + _ROWS_PER_CHUNK, height), dtype=np.float64)
        # The field basis is evaluated once per chunk of pixels for all bands at once.
        x, y = bundle.slm_to_camera(u, v[:, None, None], lam[None, None, :])  # (r, W, T)
        rows_out[:, :, top : top + v.size] = np.transpose(y + 1.0, (2, 1, 0))
        cols_out[:, :, top : top + v.size] = np.transpose(x + 1.0, (2, 1, 0))
        bar.update(v.size)
    return rows_out, cols_out


def _band_major(buffer: NDArray[np.float32]) -> BandStream:
    """A ``(T, W, H)`` buffer as the planes of an ``(H, W, T)`` array."""
    bands, width, height = buffer.shape
    return BandStream((height, width, bands), np.float32, lambda: (b.T for b in buffer))


def export_sassi_mat(
    bundle: CalibrationBundle,
    out: str | os.PathLike[str],
    *,
    wavelengths: ArrayLike | None = None,
    camera_shape: tuple[int, int] | None = None,
    node_step: int = 8,
    compression_level: int = 1,
    progress: bool = True,
) -> SassiMatExport:
    """Write ``calibstack.mat``, ``reverse_lookup.mat`` and ``README.txt`` into ``out``.

    Parameters
    ----------
    bundle
        The calibration bundle (from :func:`sassi_bench.bundle.load`).
    out
        Output folder (created; files already there are never overwritten).
    wavelengths
        Bands in nm, increasing, inside the bundle's range (default: its bin centres).
    camera_shape
        Spectral camera ``(H, W)`` (default: from the bundle's rig description).
    node_step
        Spacing (camera px) of the nodes at which the dispersion map is inverted exactly
        before bilinear interpolation (see :mod:`sassi_bench.export.camera_lookup`).
    compression_level
        zlib level of the large arrays (0-9).
    progress
        Show progress bars.

    Returns
    -------
    SassiMatExport

    Examples
    --------
    >>> from sassi_bench.bundle import load
    >>> done = export_sassi_mat(load(rig="sim"), "for_sassi")  # doctest: +SKIP
    >>> done.sizes  # doctest: +SKIP
    """
    start = time.perf_counter()
    lam = _bands(wavelengths, bundle)
    shape = camera_shape_of(bundle) if camera_shape is None else tuple(int(n) for n in camera_shape)
    folder = Path(out)
    targets = [folder / name for name in (CALIBSTACK_FILE, REVERSE_LOOKUP_FILE, README_FILE)]
    existing = [str(p) for p in targets if p.exists()]
    if existing:
        raise ProcedureError(
            step_error(
                "sassi-mat export",
                f"{', '.join(existing)} already exist (exports are never overwritten)",
                "choose a new output folder",
            )
        )
    slm_h, slm_w = bundle.slm_shape
    identity = {
        "bundle_rig": bundle.rig_name,
        "bundle_version": bundle.version,
        "bundle_manifest_sha256": sha256_file(bundle.path / MANIFEST_NAME),
    }
    sigma = np.asarray(bundle.blur_width(lam), dtype=np.float64)
    unreached = np.zeros(lam.size)
    n = lam.size
    with tqdm(total=n, desc="invert dispersion", unit="band", disable=not progress) as bar:
        lookup = solve_camera_lookup(bundle, shape, lam, step=node_step)
        bar.update(n)
    with tqdm(total=2 * n, desc=CALIBSTACK_FILE, unit="band", disable=not progress) as bar:
        write_mat(
            folder / CALIBSTACK_FILE,
            {
                "wavelengths": lam,
                "blur_sigma_px": sigma,
                "ksizes": suggested_ksizes(sigma),
                **identity,
                "calibstack_row": BandStream(
                    (*shape, n), np.float32, lambda: _calibstack_planes(lookup, "v", bar, unreached)
                ),
                "calibstack_col": BandStream(
                    (*shape, n), np.float32, lambda: _calibstack_planes(lookup, "u", bar)
                ),
            },
            compression_level=compression_level,
        )
    with tqdm(total=slm_h, desc=REVERSE_LOOKUP_FILE, unit="SLM row", disable=not progress) as bar:
        camera_rows, camera_cols = _reverse_lookup(bundle, lam, bar)
    write_mat(
        folder / REVERSE_LOOKUP_FILE,
        {
            "wavelengths": lam,
            **identity,
            "Xl": _band_major(camera_rows),
            "Yl": _band_major(camera_cols),
        },
        compression_level=compression_level,
    )
    del camera_rows, camera_cols
    readme = folder / README_FILE
    readme.write_text(
        readme_text(bundle, lookup, unreached, identity["bundle_manifest_sha256"]), "utf-8"
    )
    return SassiMatExport(
        folder=folder,
        files=tuple(targets),
        wavelengths=lam,
        camera_shape=shape,
        slm_shape=(slm_h, slm_w),
        unreached_fraction=unreached,
        seconds=time.perf_counter() - start,
    )


def readme_text(
    bundle: CalibrationBundle,
    lookup: CameraLookup,
    unreached: NDArray[np.float64],
    manifest_sha256: str,
) -> str:
    """The ``README.txt`` written beside the two files."""
    wavelengths = lookup.wavelengths
    hc, wc = lookup.camera_shape
    hl, wl = bundle.slm_shape
    t = wavelengths.size
    status = "passed" if bundle.passed else "FAILED its quality checks (published with override)"
    body = f"""\
    Calibration files for the SASSI reconstruction code (Image-Science-Lab-cmu/SASSI,
    modules/cassi.py), exported by sassi-bench from a calibration bundle.

    Source bundle : {bundle.rig_name}/{bundle.version} ({status})
    Bundle path   : {bundle.path}
    manifest.json : sha256 {manifest_sha256}
                    (manifest.json lists the sha256 of every array of the bundle)
    Bands         : T = {t}, {wavelengths[0]:.2f} - {wavelengths[-1]:.2f} nm
    Camera        : Hc x Wc = {hc} x {wc} px (spectral camera)
    SLM           : Hl x Wl = {hl} x {wl} px

    Use: put both files in <root>/calibration/ (that is where cassi.py's __main__
    loads them with scipy.io.loadmat). All indices below are MATLAB 1-based: the
    code subtracts 1. Arrays are indexed [row, column, band] in MATLAB/numpy order
    (scipy.io.loadmat returns them with exactly these shapes).

    calibstack.mat
      calibstack_row  single (Hc, Wc, T) = ({hc}, {wc}, {t})
      calibstack_col  single (Hc, Wc, T)
          For camera pixel [r, c] and band k: the SLM row / column (1-based,
          sub-pixel) whose light of band k lands on the centre of that camera
          pixel; the exact inverse of the bundle's dispersion map (solved by
          Newton's method on camera nodes every {lookup.step} px, interpolated
          bilinearly). Where several SLM pixels fall into one camera
          pixel, this is the position under the pixel's centre; round it to get
          the SLM pixel whose area contains that point.
          0 (both arrays) where no SLM pixel reaches the camera pixel: after the
          code's "- 1" that is -1, which get_cassi_img's grid_sample reads as 0
          (zero padding), so get_offset treats the pixel as streak-free. Not NaN:
          grid_sample mishandles NaN grids.
          Single precision because get_cassi_img feeds them to grid_sample with a
          float32 cube, and grid_sample refuses a grid of another dtype.
          Share of camera pixels unreached: {unreached.min():.1%} - {unreached.max():.1%}
          per band.
          Note: get_cassi_img normalises a 0-based coordinate c as (2c - H)/H with
          align_corners=False, which samples the SLM at c - 0.5 (half an SLM pixel
          up and left). That affects only the streak mask used for the offset
          estimate; the values stored here are the true positions.
      wavelengths     double (1, T): band centres in nm (cassi.py ravels it).
      blur_sigma_px   double (1, T): the bundle's Gaussian blur sigma per band
                      (camera px). Not read by cassi.py.
      ksizes          double (1, T): ceil(3 sigma) + 0.5, so that
                      filtering.gaussdiskwin(ksizes[k]) spans +/- 3 sigma. cassi.py
                      hard-codes ksizes = linspace(1, 4, T)**2 / 4 instead; to use
                      the calibrated blur replace that line by
                      ksizes = calibdata['ksizes'].ravel()
                      (on the virtual bench the hard-coded windows are narrower
                      than the blue blur: streak light beside them is taken as
                      offset and bins below 415 nm keep under 25 % of their
                      signal; with these ksizes the spectra agree with
                      sassi-bench's to 3.7 % RMS per pixel, median).
      bundle_rig, bundle_version, bundle_manifest_sha256: where this came from.

    reverse_lookup.mat
      Xl  single (Hl, Wl, T) = ({hl}, {wl}, {t}): camera ROW (1-based, sub-pixel)
          where SLM pixel [r, c] lands in band k.
      Yl  single (Hl, Wl, T): camera COLUMN (1-based) of the same point.
          Xl holds rows and Yl columns, whatever the names suggest, because that is
          what the code does: get_cassi_cube calls _get_cassi_cube(img, mask, Yl, Xl)
          (swapped), which calls cv2.remap(img, Xl, Yl) whose first map is the
          column (x) and second the row (y). So cv2.remap samples the camera image
          at column Yl - 1, row Xl - 1.
          SLM pixels whose light leaves the camera keep their outside coordinates;
          cv2.remap's constant border reads them as 0.
      wavelengths, bundle_rig, bundle_version, bundle_manifest_sha256: as above.

    Per capture (adaptive_cassi.mat, from "sassi-bench snapshot export --format
    sassi-mat"): lcos_mask uint8 (Hl, Wl) 0/255, cassi_img uint16 (Hc, Wc) raw
    camera frame, guide_img_rec uint8 RGB (h2-h1, w2-w1, 3), limits int32
    [h1 h2 w1 w2] (0-based Python slice bounds: cassi.py crops mask[h1:h2, w1:w2]).
    limits default to the whole SLM: __main__ passes the uncropped cube from
    get_cassi_cube with the cropped mask and guide to recon_superpixel, which only
    works when they have one shape; with other limits crop the cube first.
    """
    return textwrap.dedent(body)
