"""Cubes on disk: xarray Datasets written to NetCDF, and ENVI export.

The NetCDF files follow the CF conventions (``Conventions = "CF-1.10"``): every variable
has UDUNITS ``units`` (``"1"`` for dimensionless values and indices) and a ``long_name``
in words; ``wavelength`` carries its bin edges as CF ``bounds`` (``wavelength_bnds``, and
as ``wavelength_lower``/``wavelength_upper``, which files written before had); a cube in
radiance carries the per-bin ``response`` it was divided by (camera ADU per second per
unit of radiance), so that ``radiance * response`` gives back camera ADU per second per
bin without the bundle, and a snapshot also its ``exposure_time``. Readers that want the
words of a cube's units use :func:`units_label`, which also reads older files (whose
``units`` held the words).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from sassi_bench._shared.atomic import atomic_path
from sassi_bench._shared.signals import deferred_stop_signals
from sassi_bench.errors import SassiBenchError, step_error
from sassi_bench.spectra.scan import QUALITY_FLAGS, ScanCube

__all__ = [
    "CF_UNITS",
    "cube_dataset",
    "spectral_cube_dataset",
    "units_label",
    "write_envi",
    "write_netcdf",
]

#: What a cube's values are, in words (its ``long_name``) -> their UDUNITS ``units``.
CF_UNITS = {
    "relative photon radiance per bin": "1",
    "camera ADU per second per bin": "count s-1",
    "camera ADU per bin": "count",
}


def cube_dataset(
    scan: ScanCube,
    *,
    units: str,
    response: NDArray[np.floating] | None = None,
    attrs: dict[str, Any] | None = None,
) -> xr.Dataset:
    """A scan as an xarray Dataset (dims y, x, wavelength) with its quality mask.

    Examples
    --------
    >>> import numpy as np
    >>> scan = ScanCube(np.zeros((2, 3, 4), np.float32), np.zeros((2, 3), np.uint8),
    ...                 np.arange(4.0) + 500, np.arange(5.0) + 499.5, (10, 20),
    ...                 np.zeros((1, 1)), None, 1.0)
    >>> ds = cube_dataset(scan, units="relative photon radiance per bin", response=np.ones(4))
    >>> ds["radiance"].dims, int(ds.x[0]), int(ds.y[0]), ds["response"].attrs["units"]
    (('y', 'x', 'wavelength'), 20, 10, 'count s-1')
    """
    extra: dict[str, Any] = {}
    if scan.deblur is not None:
        extra.update(scan.deblur.to_attrs())
    ds = spectral_cube_dataset(
        scan.cube,
        scan.wavelengths_nm,
        scan.bin_edges_nm,
        units=units,
        quality=scan.quality,
        origin=scan.origin,
        response=response,
        title="SASSI pinhole scan",
        attrs={
            "background_check_rms": float(scan.background_check_rms or np.nan),
            **extra,
            **(attrs or {}),
        },
    )
    if scan.band_noise_psnr_db is not None:
        ds["band_noise_psnr_db"] = (
            ("wavelength",),
            np.asarray(scan.band_noise_psnr_db, dtype=np.float64),
            {
                "units": "dB",
                "long_name": "per-band PSNR of the cube against its own propagated noise",
                "description": "the cube's peak over the RMS of the deblurred spectra's "
                "photon and read noise, in camera units per second (no reference cube)",
            },
        )
    return ds


def spectral_cube_dataset(
    cube: NDArray[np.floating],
    wavelengths_nm: NDArray[np.floating],
    bin_edges_nm: NDArray[np.floating],
    *,
    units: str,
    quality: NDArray[np.uint8] | None = None,
    origin: tuple[int, int] = (0, 0),
    response: NDArray[np.floating] | None = None,
    exposure_s: float | None = None,
    title: str = "SASSI cube",
    attrs: dict[str, Any] | None = None,
) -> xr.Dataset:
    """Any cube on the SLM grid as a CF Dataset like a scan's (dims y, x, wavelength;
    ``radiance`` and a ``quality`` bit mask, 0 = good; :data:`QUALITY_FLAGS`).

    Parameters
    ----------
    cube
        (H, W, B) values.
    wavelengths_nm, bin_edges_nm
        Bin centres (B,) and edges (B + 1,).
    units
        What the values are, a key of :data:`CF_UNITS` (stored as ``long_name``; the
        UDUNITS form as ``units``).
    quality
        (H, W) bit mask (default: all good).
    origin
        (row, column) of the cube's first pixel on the SLM.
    response
        (B,) per-bin response the cube was divided by (camera ADU per second per unit of
        the cube's values), stored as the ``response`` variable.
    exposure_s
        The exposure of the frame the cube came from, stored as ``exposure_time``.
    title, attrs
        Global attributes.

    Examples
    --------
    >>> ds = spectral_cube_dataset(np.zeros((2, 3, 4), np.float32), np.arange(4.0) + 500,
    ...                            np.arange(5.0) + 499.5, units="camera ADU per bin")
    >>> ds["radiance"].shape, int(ds["quality"].sum()), ds.attrs["title"]
    ((2, 3, 4), 0, 'SASSI cube')
    >>> ds["radiance"].attrs["units"], ds["wavelength_bnds"].values[0].tolist()
    ('count', [499.5, 500.5])
    """
    if units not in CF_UNITS:
        raise SassiBenchError(
            step_error(
                "cube output",
                f"units {units!r} have no UDUNITS form here",
                f"use one of {', '.join(map(repr, CF_UNITS))} or add it to CF_UNITS",
            )
        )
    h, w, bins = cube.shape
    r0, c0 = origin
    edges = np.asarray(bin_edges_nm, dtype=np.float64)
    if quality is None:
        quality = np.zeros((h, w), np.uint8)
    variables: dict[str, Any] = {
        "radiance": (
            ("y", "x", "wavelength"),
            cube,
            {"units": CF_UNITS[units], "long_name": units, "ancillary_variables": "quality"},
        ),
        "quality": (
            ("y", "x"),
            quality,
            {
                "units": "1",
                "long_name": "quality flags of the cube's pixels",
                "flag_masks": np.array(list(QUALITY_FLAGS.values()), np.uint8),
                "flag_meanings": " ".join(QUALITY_FLAGS),
                "description": "0 = good",
            },
        ),
    }
    if response is not None:
        values = np.asarray(response, dtype=np.float64)
        if values.shape != (bins,) or CF_UNITS[units] != "1":
            raise SassiBenchError(
                step_error(
                    "cube output",
                    f"a response of shape {values.shape} for a cube of {bins} bins in {units}",
                    "pass the bundle's per-bin response with a cube divided by it (relative "
                    "radiance)",
                )
            )
        variables["response"] = (
            ("wavelength",),
            values,
            {
                "units": "count s-1",
                "long_name": f"system response per bin the cube was divided by (camera ADU "
                f"per second per unit of {units})",
                "comment": "camera ADU per second per bin = radiance * response",
            },
        )
    # A data variable, not a coordinate: xarray would list a 2-D coordinate in a global
    # "coordinates" attribute, which CF does not know. Its units are the wavelength's
    # (CF bounds inherit them; xarray writes none).
    variables["wavelength_bnds"] = (
        ("wavelength", "nv"),
        np.column_stack([edges[:-1], edges[1:]]),
        {"units": "nm", "long_name": "bin edges"},
    )
    if exposure_s is not None:
        variables["exposure_time"] = (
            (),
            float(exposure_s),
            {"units": "s", "long_name": "exposure of the spectral frame (values are per second)"},
        )
    return xr.Dataset(
        variables,
        coords={
            "y": ("y", np.arange(r0, r0 + h), {"long_name": "SLM row", "units": "1"}),
            "x": ("x", np.arange(c0, c0 + w), {"long_name": "SLM column", "units": "1"}),
            "wavelength": (
                "wavelength",
                np.asarray(wavelengths_nm),
                {
                    "units": "nm",
                    "standard_name": "radiation_wavelength",
                    "long_name": "bin centre wavelength",
                    "bounds": "wavelength_bnds",
                },
            ),
            "wavelength_lower": (
                "wavelength",
                edges[:-1],
                {"units": "nm", "long_name": "bin lower edge"},
            ),
            "wavelength_upper": (
                "wavelength",
                edges[1:],
                {"units": "nm", "long_name": "bin upper edge"},
            ),
        },
        attrs={"Conventions": "CF-1.10", "title": title, **(attrs or {})},
    )


def units_label(variable: xr.DataArray) -> str:
    """What a cube variable's values are, in words: its ``long_name``, or for files
    written before the cubes followed CF, its ``units`` (which held the words).

    Parameters
    ----------
    variable
        A cube variable (``radiance``).

    Returns
    -------
    str
        The words to show beside its values.

    Examples
    --------
    >>> units_label(xr.DataArray([1.0], attrs={"units": "1", "long_name": "relative"}))
    'relative'
    >>> units_label(xr.DataArray([1.0], attrs={"units": "camera ADU per bin"}))
    'camera ADU per bin'
    """
    return str(variable.attrs.get("long_name") or variable.attrs.get("units", ""))


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike[str], overwrite: bool = False) -> Path:
    """Write a cube Dataset to NetCDF (never over an existing file unless asked).

    The file is written under a temporary name and renamed when complete, so an
    interrupted write never leaves part of a cube under ``path``.
    """
    path = Path(path)
    if path.exists() and not overwrite:
        raise _exists("cube output", path, "choose another --out or remove the file")
    path.parent.mkdir(parents=True, exist_ok=True)
    encoding: dict[str, dict[str, Any]] = {
        "radiance": {"zlib": True, "complevel": 4},
        "quality": {"zlib": True},
    }
    # CF coordinates have no missing values: no _FillValue on them.
    for name in [*ds.coords, "wavelength_bnds"]:
        if name in ds and ds[name].dtype.kind == "f":
            encoding[name] = {"_FillValue": None}
    try:
        # Stopped inside the HDF5 writer, the process would wait on its lock for ever.
        with atomic_path(path, overwrite=overwrite) as temporary, deferred_stop_signals():
            ds.to_netcdf(temporary, engine="netcdf4", encoding=encoding)
    except FileExistsError:  # appeared while it was written
        raise _exists("cube output", path, "choose another --out or remove the file") from None
    return path


def write_envi(ds: xr.Dataset, path: str | os.PathLike[str], overwrite: bool = False) -> Path:
    """Export the radiance as an ENVI image (.hdr/.img) with wavelength, fwhm and default bands.

    Uses Spectral Python, which remote-sensing tools read; returns the header path. Both
    files are written under temporary names and renamed when complete, the header last:
    the header is what makes the pair, so an image without its header (what an export
    interrupted between the two renames leaves) is replaced.
    """
    import spectral.io.envi as envi

    header = Path(path).with_suffix(".hdr")
    image = header.with_suffix(".img")
    if header.exists() and not overwrite:
        raise _exists("ENVI export", header, "choose another path or remove it")
    lam = ds["wavelength"].values
    fwhm = (ds["wavelength_upper"] - ds["wavelength_lower"]).values
    bands = [int(np.argmin(np.abs(lam - target))) for target in (640.0, 550.0, 460.0)]
    metadata = {
        "wavelength": [f"{v:.3f}" for v in lam],
        "fwhm": [f"{v:.3f}" for v in fwhm],
        "wavelength units": "nm",
        "default bands": [b + 1 for b in bands],  # ENVI counts bands from 1
        "description": ds.attrs.get("title", "SASSI cube"),
    }
    with (
        atomic_path(header, overwrite=overwrite) as header_tmp,
        atomic_path(image, overwrite=True) as image_tmp,  # in place first
    ):
        written = [header_tmp.with_name(f"{header_tmp.name}-envi{ext}") for ext in (".hdr", ".img")]
        try:
            envi.save_image(
                str(written[0]),
                ds["radiance"].values.astype(np.float32),
                metadata=metadata,
                ext=".img",
            )
            os.replace(written[0], header_tmp)
            os.replace(written[1], image_tmp)
        finally:
            for leftover in written:
                leftover.unlink(missing_ok=True)
    return header


def _exists(step: str, path: Path, fix: str) -> SassiBenchError:
    return SassiBenchError(step_error(step, f"{path} exists", fix))
