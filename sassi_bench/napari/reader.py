"""napari readers for the workbench's cubes (NetCDF, ENVI) and snapshot videos (Zarr).

Each file opens as two image layers: an sRGB rendering of the scene (for finding things
in it) and the cube itself with wavelength as its first axis, scaled so napari's slider
reads nanometres. The cube layer's ``metadata`` holds ``wav`` (the bin centres, nm) and
``type`` (``"HSIf"``), the keys napari-hippo's tools read, and ``provenance``: the bundle
the cube was extracted with and the session, scene and light it came from (the file's
own attributes). A video adds time as the first axis, read a frame at a time.

Nothing here imports napari: the readers return napari's layer data tuples
(``(data, kwargs, "image")``), so they are tested without a display.

Examples
--------
Not run here (it needs a bench, captured sessions or files)::

    reader = get_reader("cubes/lab-spectral-colorchecker-sim-v0002.nc")
    [kwargs["name"] for _, kwargs, _ in reader("cubes/...nc")]
    # ['lab-spectral-colorchecker-sim-v0002 (sRGB)', 'lab-spectral-colorchecker-sim-v0002']
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.errors import SassiBenchError, step_error

__all__ = ["get_reader", "read_envi", "read_netcdf", "read_video"]

STEP = "napari reader"
LayerData = tuple[Any, dict[str, Any], str]
#: The provenance attributes a cube's layer shows (the workbench writes them).
PROVENANCE_KEYS = (
    "bundle_rig",
    "bundle_version",
    "session_id",
    "session_sha256",
    "scene",
    "light",
    "title",
    "units",
    "started",
    "video",
    "frame",
)


def _wavelength_axis(wav: NDArray[np.float64]) -> tuple[float, float]:
    """(scale, translate) putting the bins at their wavelengths on napari's axis: exact for
    evenly spaced bins, the mean step otherwise (``metadata['wav']`` has the exact ones)."""
    if wav.size < 2:
        return 1.0, float(wav[0]) if wav.size else 0.0
    return float((wav[-1] - wav[0]) / (wav.size - 1)), float(wav[0])


def _srgb(wav: NDArray[np.float64], cube_last: Any) -> NDArray[np.float32]:
    from sassi_bench.validate.colorimetry import cube_to_srgb

    return np.clip(cube_to_srgb(wav, cube_last), 0.0, 1.0)


def _layers(
    name: str,
    cube_first: Any,
    wav: NDArray[np.float64],
    rgb: NDArray[np.float32],
    provenance: Mapping[str, Any],
    *,
    units: str = "",
    time_axis: bool = False,
) -> list[LayerData]:
    step, start = _wavelength_axis(wav)
    lead = (1.0,) if time_axis else ()
    metadata = {
        "wav": [float(v) for v in wav],
        "type": "HSIf",
        "units": units,
        "provenance": dict(provenance),
    }
    labels = ("time", "wavelength (nm)", "y", "x") if time_axis else ("wavelength (nm)", "y", "x")
    cube_kwargs = {
        "name": name,
        "metadata": metadata,
        "scale": (*lead, step, 1.0, 1.0),
        "translate": (*(0.0,) * len(lead), start, 0.0, 0.0),
        "axis_labels": labels,
        "colormap": "gray",
        "visible": False,
    }
    first = np.asarray(cube_first[0] if time_axis else cube_first, dtype=np.float32)
    finite = first[np.isfinite(first)]
    if finite.size:  # from the data shown first: napari would read a lazy video whole
        low, high = float(finite.min()), float(finite.max())
        cube_kwargs["contrast_limits"] = (low, high if high > low else low + 1.0)
    rgb_kwargs = {
        "name": f"{name} (sRGB)",
        "rgb": True,
        "metadata": {"provenance": dict(provenance), "wav": metadata["wav"]},
        "contrast_limits": (0.0, 1.0),
    }
    if time_axis:
        rgb_kwargs["scale"] = (1.0, 1.0, 1.0)
    return [(rgb, rgb_kwargs, "image"), (cube_first, cube_kwargs, "image")]


def _provenance(attrs: Mapping[str, Any]) -> dict[str, Any]:
    found = {}
    for key in PROVENANCE_KEYS:
        value = attrs.get(key)
        if value is None or (isinstance(value, str) and not value):
            continue
        found[key] = value.item() if isinstance(value, np.generic) else value
    return found


def read_netcdf(path: str | os.PathLike[str]) -> list[LayerData]:
    """Layers of a NetCDF cube (``radiance`` with dims y, x, wavelength).

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        rgb, cube = read_netcdf("cubes/scan.nc")
        cube[1]["metadata"]["provenance"]["bundle_version"]
        # 'v0002'
    """
    import xarray as xr

    from sassi_bench.spectra.cube_io import units_label

    path = Path(path)
    with xr.open_dataset(path) as ds:
        if "radiance" not in ds or "wavelength" not in ds["radiance"].dims:
            raise SassiBenchError(
                step_error(
                    STEP,
                    f"{path} holds no 'radiance' with a 'wavelength' dimension",
                    "open a cube the workbench wrote (scan, snapshot or video frame export)",
                )
            )
        radiance = ds["radiance"].transpose("y", "x", "wavelength")
        cube_last = np.asarray(radiance.values, dtype=np.float32)
        wav = np.asarray(ds["wavelength"].values, dtype=np.float64)
        units = units_label(ds["radiance"])
        provenance = _provenance({**ds.attrs, "units": units})
    cube_first = np.ascontiguousarray(np.moveaxis(cube_last, -1, 0))
    return _layers(path.stem, cube_first, wav, _srgb(wav, cube_last), provenance, units=units)


def read_envi(path: str | os.PathLike[str]) -> list[LayerData]:
    """Layers of an ENVI cube (``.hdr`` with its ``.img``) with a ``wavelength`` list.

    A cube the workbench exported has its NetCDF twin beside it (same stem); its
    provenance is shown when it is there.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        rgb, cube = read_envi("cubes/scan.hdr")
    """
    import spectral.io.envi as envi

    header = Path(path).with_suffix(".hdr")
    try:
        image = envi.open(str(header))
    except (OSError, envi.EnviException) as exc:
        raise SassiBenchError(
            step_error(STEP, f"cannot open {header} ({exc})", "check the .hdr and its .img")
        ) from exc
    wavelengths = image.metadata.get("wavelength")
    if not wavelengths:
        raise SassiBenchError(
            step_error(
                STEP,
                f"{header} has no 'wavelength' list",
                "open a cube whose header lists its band centres",
            )
        )
    wav = np.asarray([float(v) for v in wavelengths], dtype=np.float64)
    cube_last = np.asarray(image.load(), dtype=np.float32)
    provenance: dict[str, Any] = {"title": image.metadata.get("description", "")}
    twin = header.with_suffix(".nc")
    if twin.is_file():
        import xarray as xr

        with xr.open_dataset(twin) as ds:
            provenance = _provenance(ds.attrs) or provenance
    cube_first = np.ascontiguousarray(np.moveaxis(cube_last, -1, 0))
    return _layers(header.stem, cube_first, wav, _srgb(wav, cube_last), provenance)


class _LazyFrames:
    """A (T, ...) array-like whose frame ``t`` is made by ``make(t)`` when napari asks for it
    (napari slices lazily any object with shape, dtype, ndim and ``__getitem__``); the
    last frame made is kept."""

    def __init__(self, shape: tuple[int, ...], make: Callable[[int], NDArray[np.float32]]):
        self.shape = shape
        self.dtype = np.dtype(np.float32)
        self.ndim = len(shape)
        self._make = make
        self._cached: tuple[int, NDArray[np.float32]] | None = None

    def frame(self, t: int) -> NDArray[np.float32]:
        """Frame ``t``."""
        if self._cached is None or self._cached[0] != t:
            self._cached = (t, self._make(t))
        return self._cached[1]

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key: Any) -> Any:
        key = key if isinstance(key, tuple) else (key,)
        first, rest = key[0], key[1:]
        if isinstance(first, (int, np.integer)):
            return self.frame(int(first))[rest] if rest else self.frame(int(first))
        indices = range(self.shape[0])[first]
        return np.stack([self.frame(t)[rest] if rest else self.frame(t) for t in indices])

    def __array__(self, dtype: Any = None, copy: Any = None) -> NDArray[Any]:
        return np.asarray(self[:], dtype=dtype)


def read_video(path: str | os.PathLike[str]) -> list[LayerData]:
    """Layers of a snapshot video store (``video.zarr``): time, then wavelength, y, x; a
    frame's dense cube and its sRGB rendering are made when the frame is shown.

    Examples
    --------
    Not run here (it needs a bench, captured sessions or files)::

        rgb, cube = read_video("live/video.zarr")
        cube[0].shape
        # (10, 68, 400, 640)
    """
    import zarr

    path = Path(path)
    try:
        group = zarr.open_group(str(path), mode="r")
        attrs = dict(group.attrs)
        frames = int(attrs["frames"])
        wav = np.asarray(attrs["wavelength_nm"], dtype=np.float64)
        shape = tuple(int(n) for n in group["labels"].shape[1:])
    except (KeyError, ValueError, OSError, zarr.errors.GroupNotFoundError) as exc:
        raise SassiBenchError(
            step_error(
                STEP,
                f"{path} is not a snapshot video store ({exc})",
                "open the video.zarr folder a snapshot video run wrote",
            )
        ) from exc
    if frames == 0:
        raise SassiBenchError(
            step_error(STEP, f"{path} holds no complete frame", "record a video first")
        )
    from sassi_bench.snapshot.video_store import read_frame

    def dense(t: int) -> NDArray[np.float32]:
        cube, _ = read_frame(path, t)
        return np.ascontiguousarray(np.moveaxis(np.asarray(cube.dense(), np.float32), -1, 0))

    lazy = _LazyFrames((frames, wav.size, *shape), dense)
    rgb = _LazyFrames((frames, *shape, 3), lambda t: _srgb(wav, np.moveaxis(lazy.frame(t), 0, -1)))
    provenance = _provenance({**attrs, "units": attrs.get("units", "")})
    provenance["frames"] = frames
    return _layers(
        path.stem, lazy, wav, rgb, provenance, units=str(attrs.get("units", "")), time_axis=True
    )


def _reader_for(path: Path) -> Callable[[Any], list[LayerData]] | None:
    if path.suffix == ".nc":
        return read_netcdf
    if path.suffix in (".hdr", ".img") and path.with_suffix(".hdr").is_file():
        return read_envi
    if path.is_dir() and (path / "zarr.json").is_file() and (path / "labels").is_dir():
        return read_video
    return None


def get_reader(path: str | os.PathLike[str] | list[Any]) -> Callable[..., list[LayerData]] | None:
    """napari's reader hook: a function that reads ``path`` (or each of several paths), or
    None when this plugin does not read it.

    Examples
    --------
    >>> get_reader("photo.png") is None
    True
    >>> get_reader("scan.nc").__name__
    'read_paths'
    """
    paths = [Path(p) for p in (path if isinstance(path, list) else [path])]
    readers = [_reader_for(p) for p in paths]
    if not paths or any(r is None for r in readers):
        return None

    def read_paths(_: Any = None) -> list[LayerData]:
        layers: list[LayerData] = []
        for reader, one in zip(readers, paths, strict=True):
            layers.extend(reader(one))  # type: ignore[misc]
        return layers

    return read_paths
