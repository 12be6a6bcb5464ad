"""A snapshot video on disk: a Zarr store of rank-1 frames in factored form.

A dense cube a frame (698 x 931 x 68 float32: 177 MB) is far more than a camera can stream
to disk at video rate, so the store keeps the exact factored rank-1 form
(:class:`~sassi_bench.snapshot.factored.Rank1Cube`) of every frame:

========================  ========================  =========================================
array                     shape, dtype              what
========================  ========================  =========================================
``labels``                (T, H, W) int32           the region of every SLM pixel
``scale``                 (T, H, W) float32         every pixel's scale
``spectra``               (T, R, B) float32         one spectrum per region (rows past
                                                    ``regions[t]`` unused)
``regions``               (T,) int32                regions of each frame
``mask``                  (T, H, W) bool            the open pixels the frame was taken with
``time_s``                (T,) float64              capture time after ``started`` (seconds)
``frame_index``           (T,) int64                capture number (frames dropped leave gaps)
========================  ========================  =========================================

The store's attributes hold the bundle (rig, version), the bins (``wavelength_nm``,
``bin_edges_nm``), the units, the start time, the run's settings, and ``frames``: the
number of complete frames. A frame's arrays are written first and ``frames`` counted up
after, so a run stopped at any moment leaves every counted frame readable.
:func:`read_frame` gives a frame back; :func:`export_frame` writes it as NetCDF (and ENVI).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from numpy.typing import NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot.factored import Rank1Cube
from sassi_bench.snapshot.reconstruct import snapshot_dataset, write_cube

__all__ = ["VideoStore", "export_frame", "read_frame"]

STEP = "snapshot video store"


class VideoStore:
    """Appends rank-1 frames to a new Zarr store (see the module docstring).

    Parameters
    ----------
    path
        The store's folder; must not exist.
    bundle
        The bundle the frames are reconstructed with.
    units
        Units of the spectra.
    attrs
        Further attributes (rig, scene, settings, start time).

    Examples
    --------
    Not run here (it needs captured frames)::

        store = VideoStore("live.zarr", bundle, units=units)
        store.append(frame.rank1, frame.mask, time_s=0.05, frame_index=0)
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        bundle: CalibrationBundle,
        *,
        units: str,
        attrs: dict[str, Any] | None = None,
    ) -> None:
        self.path = Path(path)
        if self.path.exists():
            raise ProcedureError(
                step_error(STEP, f"{self.path} exists", "write into a new --out folder")
            )
        h, w = bundle.slm_shape
        self.bands = int(bundle.wavelengths.size)
        self.group = zarr.open_group(str(self.path), mode="w-")
        frame = (1, h, w)
        self.labels = self.group.create_array("labels", shape=(0, h, w), chunks=frame, dtype="i4")
        self.scale = self.group.create_array("scale", shape=(0, h, w), chunks=frame, dtype="f4")
        self.mask = self.group.create_array("mask", shape=(0, h, w), chunks=frame, dtype="bool")
        self.capacity = 1024
        self.spectra = self.group.create_array(
            "spectra", shape=(0, self.capacity, self.bands), chunks=(1, 1024, self.bands),
            dtype="f4",
        )  # fmt: skip
        self.regions = self.group.create_array("regions", shape=(0,), chunks=(4096,), dtype="i4")
        self.time_s = self.group.create_array("time_s", shape=(0,), chunks=(4096,), dtype="f8")
        self.frame_index = self.group.create_array(
            "frame_index", shape=(0,), chunks=(4096,), dtype="i8"
        )
        self.frames = 0
        self.last_index = -1
        self.group.attrs.update(
            {
                "title": "SASSI snapshot video (rank-1 per region, factored)",
                "bundle_rig": bundle.rig_name,
                "bundle_version": bundle.version,
                "units": units,
                "wavelength_nm": [float(v) for v in bundle.wavelengths],
                "bin_edges_nm": [float(v) for v in bundle.bin_edges],
                "frames": 0,
                **(attrs or {}),
            }
        )

    def append(
        self, cube: Rank1Cube, mask: NDArray[np.bool_], *, time_s: float, frame_index: int
    ) -> int:
        """Write one frame; returns the number of frames stored.

        Parameters
        ----------
        cube
            The frame's rank-1 cube in factored form.
        mask
            The open pixels it was taken with.
        time_s
            Its capture time after the start (seconds).
        frame_index
            Its capture number.

        Returns
        -------
        int
        """
        t = self.frames
        regions = cube.spectra.shape[0]
        if regions > self.capacity:
            self.capacity = max(regions, 2 * self.capacity)
            self.spectra.resize((t, self.capacity, self.bands))
        for array in (self.labels, self.scale, self.mask):
            array.resize((t + 1, *array.shape[1:]))
        self.labels[t] = cube.labels.astype(np.int32, copy=False)
        self.scale[t] = cube.scale
        self.mask[t] = mask
        self.spectra.resize((t + 1, self.capacity, self.bands))
        padded = np.zeros((self.capacity, self.bands), np.float32)
        padded[:regions] = cube.spectra
        self.spectra[t] = padded
        for array, value in (
            (self.regions, regions),
            (self.time_s, time_s),
            (self.frame_index, frame_index),
        ):
            array.resize((t + 1,))
            array[t] = value
        self.frames = t + 1
        self.last_index = int(frame_index)
        self.group.attrs["frames"] = self.frames  # last: the frame is complete
        return self.frames

    def update(self, **attrs: Any) -> None:
        """Record further attributes (e.g. the run's totals when it ends)."""
        self.group.attrs.update(attrs)


def _open(path: str | os.PathLike[str]) -> zarr.Group:
    try:
        return zarr.open_group(str(path), mode="r")
    except (FileNotFoundError, zarr.errors.GroupNotFoundError) as exc:
        raise ProcedureError(
            step_error(STEP, f"no video store at {path}", "give the video.zarr of a live run")
        ) from exc


def read_frame(path: str | os.PathLike[str], t: int) -> tuple[Rank1Cube, dict[str, Any]]:
    """Frame ``t`` of a video store, and the store's attributes.

    Parameters
    ----------
    path
        The store (``<out>/video.zarr``).
    t
        Frame number, 0 .. frames - 1 (negative: from the end).

    Returns
    -------
    cube : Rank1Cube
    attrs : dict
        The store's attributes, with ``time_s`` and ``frame_index`` of the frame.

    Examples
    --------
    Not run here (it needs captured frames)::

        cube, attrs = read_frame("live/video.zarr", 0)
    """
    group = _open(path)
    attrs = dict(group.attrs)
    frames = int(attrs.get("frames", 0))
    if not -frames <= t < frames:
        raise ProcedureError(
            step_error(STEP, f"frame {t} of a store of {frames} frames", f"pick 0..{frames - 1}")
        )
    t %= frames
    regions = int(group["regions"][t])
    cube = Rank1Cube(
        np.asarray(group["labels"][t]).astype(np.intp),
        np.asarray(group["scale"][t]),
        np.asarray(group["spectra"][t, :regions]),
    )
    attrs.update(time_s=float(group["time_s"][t]), frame_index=int(group["frame_index"][t]))
    return cube, attrs


def export_frame(
    path: str | os.PathLike[str],
    t: int,
    bundle: CalibrationBundle,
    out: str | os.PathLike[str],
    *,
    envi: bool = True,
) -> list[Path]:
    """Write frame ``t`` of a video store as a NetCDF cube (and ENVI) like a snapshot's.

    Parameters
    ----------
    path
        The store.
    t
        Frame number.
    bundle
        The bundle of the store (checked against the store's version).
    out
        The NetCDF file to write (ENVI beside it, same stem); never over an existing file.
    envi
        Also write ENVI.

    Returns
    -------
    list of pathlib.Path

    Examples
    --------
    Not run here (it needs captured frames)::

        export_frame("live/video.zarr", 3, bundle, "live/f003.nc")
    """
    cube, attrs = read_frame(path, t)
    if attrs["bundle_version"] != bundle.version or attrs["bundle_rig"] != bundle.rig_name:
        raise ProcedureError(
            step_error(
                STEP,
                f"the store was written with bundle {attrs['bundle_rig']}/"
                f"{attrs['bundle_version']}, not {bundle.rig_name}/{bundle.version}",
                f"load bundle {attrs['bundle_version']} (--bundle)",
            )
        )
    ds = snapshot_dataset(
        cube.dense(), bundle, units=attrs["units"], method="rank-1 per region",
        attrs={"video": str(path), "frame": int(t), "time_s": attrs["time_s"],
               "frame_index": attrs["frame_index"]},
    )  # fmt: skip
    target = Path(out)
    return write_cube(ds, target, envi=target.with_suffix("") if envi else None)
