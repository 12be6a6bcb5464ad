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

Row window: ``__main__`` hard-codes ``vsize = 3``, the rows ``_get_cassi_cube`` sums
around each streak. The best window depends on the capture's mask and exposure, so it is
not written here but into each capture's ``adaptive_cassi.mat``, chosen by their own
extraction on that capture (:mod:`sassi_bench.export.window_choice`).
:func:`sassi_tables` gives the four tables in memory, as ``__main__`` hands them to
``get_cassi_cube``, for that choice.

Size: every variable is zlib-compressed (MAT v7 ``miCOMPRESSED``, which scipy and
MATLAB read transparently). Sub-pixel float32 positions hardly compress (their low
mantissa bits are noise), so positions are stored rounded to ``position_quantum_px``
(1/64 px by default: at most 1/128 px off, a quarter of the calibration's own error)
and compressed at level 6, which makes the files about four times smaller;
``position_quantum_px=0`` stores them exactly.

Each capture (``adaptive_cassi.mat``) is written by :mod:`sassi_bench.export.adaptive_cassi`.

Examples
--------
Not run here (it builds lookup tables over the whole camera)::

    from sassi_bench.bundle import load
    result = export_sassi_mat(load(rig="sim"), "for_sassi/")
    sorted(p.name for p in result.files)
    # ['README.txt', 'calibstack.mat', 'reverse_lookup.mat']
"""

from __future__ import annotations

import os
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
from sassi_bench.export.sassi_readme import readme_text
from sassi_bench.export.window_choice import SassiTables

__all__ = [
    "CALIBSTACK_FILE",
    "DEFAULT_QUANTUM_PX",
    "README_FILE",
    "REVERSE_LOOKUP_FILE",
    "WAVELENGTH_PRESETS",
    "SassiMatExport",
    "camera_shape_of",
    "export_sassi_mat",
    "preset_wavelengths",
    "sassi_tables",
    "suggested_ksizes",
]

CALIBSTACK_FILE = "calibstack.mat"
REVERSE_LOOKUP_FILE = "reverse_lookup.mat"
README_FILE = "README.txt"
#: SLM rows evaluated per call while building ``Xl``/``Yl`` (bounds the temporaries).
_ROWS_PER_CHUNK = 32
#: Default rounding of the stored positions (px): at most 1/128 px off.
DEFAULT_QUANTUM_PX = 1.0 / 64.0
#: zlib levels: level 6 pays off only once the noise bits are rounded away.
_LEVEL_EXACT, _LEVEL_QUANTISED = 1, 6
#: ``wavelengths`` presets: name -> what it selects.
WAVELENGTH_PRESETS = {
    "bins": "the bundle's bin centres (the default)",
    "paper": "every multiple of 10 nm inside the bundle's range (the SASSI paper's 10 nm "
    "resolution over the visible)",
    "10nm": "the same as paper",
}


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
    position_quantum_px
        Rounding of the stored positions (0: exact).
    """

    folder: Path
    files: tuple[Path, ...]
    wavelengths: NDArray[np.float64]
    camera_shape: tuple[int, int]
    slm_shape: tuple[int, int]
    unreached_fraction: NDArray[np.float64]
    seconds: float
    position_quantum_px: float

    @property
    def sizes(self) -> dict[str, int]:
        """File name -> size in bytes."""
        return {p.name: p.stat().st_size for p in self.files}


def camera_shape_of(bundle: CalibrationBundle) -> tuple[int, int]:
    """Spectral camera ``(H, W)`` from the rig description stored in the bundle.

    Examples
    --------
    Not run here (it needs the bundle of a rig that names its spectral camera)::

        camera_shape_of(load(rig="sim"))
        # (512, 800)
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


def preset_wavelengths(name: str, bundle: CalibrationBundle) -> NDArray[np.float64]:
    """The bands of a :data:`WAVELENGTH_PRESETS` name for ``bundle``.

    Parameters
    ----------
    name
        ``"bins"`` (the bundle's bin centres) or ``"paper"``/``"10nm"`` (every multiple
        of 10 nm inside the bundle's bin edges).
    bundle
        The calibration bundle.

    Returns
    -------
    ndarray
        The bands in nm, increasing.

    Raises
    ------
    ProcedureError
        If the name is not a preset.

    Examples
    --------
    >>> preset_wavelengths("paper", bundle)[[0, -1]].tolist()
    [400.0, 700.0]
    """
    key = name.strip().lower()
    if key == "bins":
        return np.asarray(bundle.wavelengths, dtype=np.float64)
    if key in ("paper", "10nm"):
        edges = bundle.bin_edges
        return 10.0 * np.arange(np.ceil(edges[0] / 10.0), np.floor(edges[-1] / 10.0) + 1)
    raise ProcedureError(
        step_error(
            "sassi-mat export",
            f"no wavelength preset {name!r}",
            f"use one of {', '.join(WAVELENGTH_PRESETS)}, or a list of nm",
        )
    )


def _bands(wavelengths: ArrayLike | str | None, bundle: CalibrationBundle) -> NDArray[np.float64]:
    if isinstance(wavelengths, str):
        wavelengths = preset_wavelengths(wavelengths, bundle)
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
                "choose bands inside that range (the default is the bundle's bin centres; "
                "--wavelengths paper takes the 10 nm grid inside it)",
            )
        )
    if np.any(np.diff(lam) <= 0):
        raise ProcedureError(
            step_error("sassi-mat export", "bands are not increasing", "sort them, no repeats")
        )
    return lam


def _check_quantum(quantum: float) -> float:
    """0 (exact) or a power of two in px (so that float32 holds the rounded values
    exactly)."""
    quantum = float(quantum)
    if quantum == 0.0:
        return 0.0
    exponent = np.log2(quantum) if quantum > 0 else np.nan
    if not (np.isfinite(exponent) and exponent == round(exponent) and -12 <= exponent <= 0):
        raise ProcedureError(
            step_error(
                "sassi-mat export",
                f"position quantum {quantum} px is not 0 or a power of two from 1/4096 to 1",
                "pass e.g. 1/64 (the default), 1/256, or 0 for exact positions",
            )
        )
    return quantum


def _quantise(values: NDArray[np.float32], quantum: float) -> NDArray[np.float32]:
    """Round ``values`` in place to multiples of ``quantum`` (0: leave them)."""
    if quantum:
        values *= np.float32(1.0 / quantum)
        np.rint(values, out=values)
        values *= np.float32(quantum)
    return values


def _calibstack_planes(
    lookup: CameraLookup,
    axis: str,
    bar: tqdm,
    quantum: float,
    unreached: NDArray[np.float64] | None = None,
) -> Iterator[NDArray[np.float32]]:
    """1-based SLM row (``axis="v"``) or column (``"u"``) per camera pixel, band by band,
    rounded to ``quantum``; 0 where unreached."""
    for t in range(lookup.wavelengths.size):
        u, v = lookup.band(t)
        plane = v if axis == "v" else u
        missing = np.isnan(plane)
        if unreached is not None:
            unreached[t] = missing.mean()
        plane += 1.0
        plane[missing] = 0.0
        _quantise(plane, quantum)
        bar.update()
        yield plane


def _reverse_lookup(
    bundle: CalibrationBundle, lam: NDArray[np.float64], bar: tqdm, quantum: float
) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """1-based camera row and column of every SLM pixel per band, rounded to ``quantum``,
    band-major ``(T, W, H)`` (the column-major order of an ``(H, W, T)`` MATLAB array)."""
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
    return _quantise(rows_out, quantum), _quantise(cols_out, quantum)


def _band_major(buffer: NDArray[np.float32]) -> BandStream:
    """A ``(T, W, H)`` buffer as the planes of an ``(H, W, T)`` array."""
    bands, width, height = buffer.shape
    return BandStream((height, width, bands), np.float32, lambda: (b.T for b in buffer))


def sassi_tables(
    bundle: CalibrationBundle,
    wavelengths: ArrayLike | str | None = None,
    *,
    camera_shape: tuple[int, int] | None = None,
    position_quantum_px: float = DEFAULT_QUANTUM_PX,
    node_step: int = 8,
) -> SassiTables:
    """The four tables :func:`export_sassi_mat` writes, in memory and 0-based, as
    ``cassi.py``'s ``__main__`` passes them to ``get_cassi_cube`` (the files' values
    minus 1, float32).

    Parameters
    ----------
    bundle, wavelengths, camera_shape, position_quantum_px, node_step
        As for :func:`export_sassi_mat`.

    Returns
    -------
    SassiTables

    Examples
    --------
    Not run here (it builds lookup tables over the whole camera)::

        tables = sassi_tables(load(rig="sim"))
        tables.xl.shape, tables.calibstack_row.shape
        # ((400, 640, 68), (512, 800, 68))
    """
    lam = _bands(wavelengths, bundle)
    shape = camera_shape_of(bundle) if camera_shape is None else tuple(int(n) for n in camera_shape)
    quantum = _check_quantum(position_quantum_px)
    lookup = solve_camera_lookup(bundle, shape, lam, step=node_step)
    row = np.empty((*shape, lam.size), dtype=np.float32)
    col = np.empty_like(row)
    bar = tqdm(disable=True)
    for t, plane in enumerate(_calibstack_planes(lookup, "v", bar, quantum)):
        row[:, :, t] = plane - 1.0
    for t, plane in enumerate(_calibstack_planes(lookup, "u", bar, quantum)):
        col[:, :, t] = plane - 1.0
    camera_rows, camera_cols = _reverse_lookup(bundle, lam, bar, quantum)  # (T, Wl, Hl)
    xl = np.ascontiguousarray(np.transpose(camera_rows, (2, 1, 0))) - np.float32(1.0)
    del camera_rows
    yl = np.ascontiguousarray(np.transpose(camera_cols, (2, 1, 0))) - np.float32(1.0)
    return SassiTables(xl=xl, yl=yl, calibstack_row=row, calibstack_col=col)


def export_sassi_mat(
    bundle: CalibrationBundle,
    out: str | os.PathLike[str],
    *,
    wavelengths: ArrayLike | str | None = None,
    camera_shape: tuple[int, int] | None = None,
    position_quantum_px: float = DEFAULT_QUANTUM_PX,
    node_step: int = 8,
    compression_level: int | None = None,
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
        Bands in nm, increasing, inside the bundle's range, or a
        :data:`WAVELENGTH_PRESETS` name (default: the bundle's bin centres).
    camera_shape
        Spectral camera ``(H, W)`` (default: from the bundle's rig description).
    position_quantum_px
        Store positions rounded to this (a power of two, px; at most half of it off);
        0 stores them exactly.
    node_step
        Spacing (camera px) of the nodes at which the dispersion map is inverted exactly
        before bilinear interpolation (see :mod:`sassi_bench.export.camera_lookup`).
    compression_level
        zlib level of the large arrays, 0-9 (default: 6 for rounded positions, 1 for
        exact ones, whose noise bits no level compresses).
    progress
        Show progress bars.

    Returns
    -------
    SassiMatExport

    Examples
    --------
    Not run here (it builds lookup tables over the whole camera)::

        from sassi_bench.bundle import load
        done = export_sassi_mat(load(rig="sim"), "for_sassi")
        done.sizes
    """
    start = time.perf_counter()
    lam = _bands(wavelengths, bundle)
    shape = camera_shape_of(bundle) if camera_shape is None else tuple(int(n) for n in camera_shape)
    quantum = _check_quantum(position_quantum_px)
    if compression_level is None:
        compression_level = _LEVEL_QUANTISED if quantum else _LEVEL_EXACT
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
        "position_quantum_px": quantum,
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
                    (*shape, n),
                    np.float32,
                    lambda: _calibstack_planes(lookup, "v", bar, quantum, unreached),
                ),
                "calibstack_col": BandStream(
                    (*shape, n), np.float32, lambda: _calibstack_planes(lookup, "u", bar, quantum)
                ),
            },
            compression_level=compression_level,
        )
    with tqdm(total=slm_h, desc=REVERSE_LOOKUP_FILE, unit="SLM row", disable=not progress) as bar:
        camera_rows, camera_cols = _reverse_lookup(bundle, lam, bar, quantum)
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
        readme_text(
            bundle, lookup, unreached, identity["bundle_manifest_sha256"],
            quantum=quantum,
        ),
        "utf-8",
    )  # fmt: skip
    return SassiMatExport(
        folder=folder,
        files=tuple(targets),
        wavelengths=lam,
        camera_shape=shape,
        slm_shape=(slm_h, slm_w),
        unreached_fraction=unreached,
        seconds=time.perf_counter() - start,
        position_quantum_px=quantum,
    )
