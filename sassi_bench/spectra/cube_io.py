"""Cubes on disk: xarray Datasets written to NetCDF, and ENVI export."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from sassi_bench.errors import SassiBenchError, step_error
from sassi_bench.spectra.scan import QUALITY_FLAGS, ScanCube

__all__ = ["cube_dataset", "spectral_cube_dataset", "write_envi", "write_netcdf"]


def cube_dataset(scan: ScanCube, *, units: str, attrs: dict[str, Any] | None = None) -> xr.Dataset:
    """A scan as an xarray Dataset (dims y, x, wavelength) with its quality mask.

    Examples
    --------
    >>> import numpy as np
    >>> scan = ScanCube(np.zeros((2, 3, 4), np.float32), np.zeros((2, 3), np.uint8),
    ...                 np.arange(4.0) + 500, np.arange(5.0) + 499.5, (10, 20),
    ...                 np.zeros((1, 1)), None, 1.0)
    >>> ds = cube_dataset(scan, units="relative photon radiance")
    >>> ds["radiance"].dims, int(ds.x[0]), int(ds.y[0])
    (('y', 'x', 'wavelength'), 20, 10)
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
                "photon and read noise, in camera units per second (no truth)",
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
    title: str = "SASSI cube",
    attrs: dict[str, Any] | None = None,
) -> xr.Dataset:
    """Any cube on the SLM grid as an xarray Dataset like a scan's (dims y, x, wavelength;
    ``radiance`` and a ``quality`` bit mask, 0 = good; :data:`QUALITY_FLAGS`).

    Examples
    --------
    >>> ds = spectral_cube_dataset(np.zeros((2, 3, 4), np.float32), np.arange(4.0) + 500,
    ...                            np.arange(5.0) + 499.5, units="camera ADU per bin")
    >>> ds["radiance"].shape, int(ds["quality"].sum()), ds.attrs["title"]
    ((2, 3, 4), 0, 'SASSI cube')
    """
    h, w, _ = cube.shape
    r0, c0 = origin
    edges = np.asarray(bin_edges_nm)
    if quality is None:
        quality = np.zeros((h, w), np.uint8)
    return xr.Dataset(
        {
            "radiance": (("y", "x", "wavelength"), cube, {"units": units}),
            "quality": (
                ("y", "x"),
                quality,
                {
                    "flag_masks": list(QUALITY_FLAGS.values()),
                    "flag_meanings": " ".join(QUALITY_FLAGS),
                    "description": "0 = good",
                },
            ),
        },
        coords={
            "y": ("y", np.arange(r0, r0 + h), {"long_name": "SLM row", "units": "pixel"}),
            "x": ("x", np.arange(c0, c0 + w), {"long_name": "SLM column", "units": "pixel"}),
            "wavelength": ("wavelength", np.asarray(wavelengths_nm), {"units": "nm"}),
            "wavelength_lower": ("wavelength", edges[:-1], {"units": "nm"}),
            "wavelength_upper": ("wavelength", edges[1:], {"units": "nm"}),
        },
        attrs={"title": title, **(attrs or {})},
    )


def write_netcdf(ds: xr.Dataset, path: str | os.PathLike[str], overwrite: bool = False) -> Path:
    """Write a cube Dataset to NetCDF (never over an existing file unless asked)."""
    path = Path(path)
    if path.exists() and not overwrite:
        raise SassiBenchError(
            step_error("cube output", f"{path} exists", "choose another --out or remove the file")
        )
    path.parent.mkdir(parents=True, exist_ok=True)
    encoding = {"radiance": {"zlib": True, "complevel": 4}, "quality": {"zlib": True}}
    ds.to_netcdf(path, engine="netcdf4", encoding=encoding)
    return path


def write_envi(ds: xr.Dataset, path: str | os.PathLike[str], overwrite: bool = False) -> Path:
    """Export the radiance as an ENVI image (.hdr/.img) with wavelength, fwhm and default bands.

    Uses Spectral Python, which remote-sensing tools read; returns the header path.
    """
    import spectral.io.envi as envi

    header = Path(path).with_suffix(".hdr")
    if header.exists() and not overwrite:
        raise SassiBenchError(
            step_error("ENVI export", f"{header} exists", "choose another path or remove it")
        )
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
    envi.save_image(
        str(header),
        ds["radiance"].values.astype(np.float32),
        metadata=metadata,
        force=overwrite,
        ext=".img",
    )
    return header
