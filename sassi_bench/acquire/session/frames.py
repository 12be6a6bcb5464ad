"""``frames.zarr/``: a session's frames, one Zarr v3 array per camera, one chunk per frame.

A camera's array is ``(n, H, W)`` (``spectral``) or ``(n, H, W, 3)`` (``guide``), with one
slot per plan step of that camera (a step's slot is its rank among them). It is created
when the camera's first frame is written, with that frame's shape and dtype; later frames
must match. Chunks are compressed with :data:`FRAME_CODEC` and fsync'd, with every folder
up to the store, as soon as they are written.

Examples
--------
>>> import tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> FrameStore.create(folder, {"session": "demo"})
>>> store = FrameStore(folder, {"spectral": [0, 1]})
>>> store.write("spectral", 1, np.full((2, 3), 7, np.uint16), replace_ok=True, where="demo")
>>> store.read("spectral", 1).tolist(), store.array("guide") is None
([[7, 7, 7], [7, 7, 7]], True)
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import zarr
from numpy.typing import NDArray
from zarr.codecs import BloscCodec, BloscShuffle
from zarr.storage import LocalStore

from sassi_bench._shared.arrays import check_dtype_kind, check_shape
from sassi_bench._shared.atomic import fsync_dir, fsync_file
from sassi_bench._shared.disk import DISK_FULL_FIX, disk_full_cause, is_disk_full
from sassi_bench.acquire.session.errors import SessionError, SessionIntegrityError, session_error

__all__ = ["FRAMES_DIR", "FRAME_CODEC", "FrameStore", "check_frame", "frame_sha256"]

FRAMES_DIR = "frames.zarr"
#: The compressor of every frame chunk: zstd after a byte shuffle, which puts the 16-bit
#: pixels' high bytes (nearly constant) together. On simulated prototype frames it keeps
#: 0.48 of the bytes against 0.60 for plain zstd, and encodes in half the CPU time; it
#: beats bit-shuffle (0.51) on these noisy frames. Lossless coding cannot go much
#: further: the frames' shot and read noise alone is 0.41 of the raw bytes; JPEG-LS keeps
#: 0.45 at three times the encoding and fifteen times the decoding CPU
#: (``benchmarks/bench_codecs.py``). Each array records its codec, so frames written with
#: an earlier one still read.
FRAME_CODEC = BloscCodec(cname="zstd", clevel=3, shuffle=BloscShuffle.shuffle)
#: The shape of a frame of each canonical camera: grey spectral, RGB guide.
_FRAME_SHAPES = {"spectral": ("H", "W"), "guide": ("H", "W", 3)}


def frame_sha256(data: NDArray[Any]) -> str:
    """SHA-256 (hex) of a frame's pixel bytes: C order, little-endian.

    Examples
    --------
    >>> frame_sha256(np.zeros((1, 1), np.uint16))[:12]
    '96a296d224f2'
    """
    arr = np.asarray(data)
    little = arr.astype(arr.dtype.newbyteorder("<"), copy=False)
    return hashlib.sha256(np.ascontiguousarray(little).tobytes()).hexdigest()


def check_frame(where: str, camera: str, frame_camera: str, data: NDArray[Any]) -> None:
    """Refuse pixels that cannot be ``camera``'s frame: another camera, shape or dtype.

    Raises
    ------
    SessionError
        Naming ``where``, the cause and the fix.

    Examples
    --------
    >>> check_frame("write", "guide", "guide", np.zeros((4, 5, 3), np.uint8))
    """
    # Adapters may name cameras by device id; only the two canonical names are checked.
    if frame_camera in ("spectral", "guide") and frame_camera != camera:
        raise session_error(
            where,
            f"the step is for the {camera} camera but the frame came from {frame_camera}",
            f"capture with rig.{camera}_camera",
        )
    if camera in _FRAME_SHAPES:
        check_shape(
            data,
            _FRAME_SHAPES[camera],
            step=where,
            name=f"the {camera} frame",
            fix=f"capture with rig.{camera}_camera",
            error=SessionError,
        )
    check_dtype_kind(
        data, "biuf", step=where, name="the frame", fix="pass camera pixels", error=SessionError
    )


class FrameStore:
    """The frames of the session in ``folder``.

    Parameters
    ----------
    folder
        The session folder (holding ``frames.zarr``).
    steps
        Per camera, the plan step of each of its slots (kept in the array's attributes).
    """

    def __init__(self, folder: Path, steps: Mapping[str, Sequence[int]]) -> None:
        self._root = folder / FRAMES_DIR
        self._steps = {camera: list(indices) for camera, indices in steps.items()}
        self._store = LocalStore(self._root)
        self._group = zarr.open_group(store=self._store, mode="r+")
        self._arrays: dict[str, zarr.Array] = {}

    @staticmethod
    def create(folder: Path, attributes: Mapping[str, Any]) -> None:
        """Create an empty store in ``folder`` with the group ``attributes``."""
        zarr.create_group(store=LocalStore(folder / FRAMES_DIR), attributes=dict(attributes))

    def array(self, camera: str) -> zarr.Array | None:
        """The camera's array, or None before its first frame."""
        if camera not in self._arrays:
            if not (self._root / camera / "zarr.json").is_file():
                return None
            self._arrays[camera] = zarr.open_array(
                store=self._store, path=camera, mode="r+", config={"write_empty_chunks": True}
            )
        return self._arrays[camera]

    def write(
        self, camera: str, slot: int, data: NDArray[Any], *, replace_ok: bool, where: str
    ) -> None:
        """Store ``data`` at ``slot`` of the camera's array and fsync it.

        Parameters
        ----------
        camera, slot
            Where the frame goes.
        data
            The frame's pixels.
        replace_ok
            Whether the camera's array may be made anew for another shape or dtype: true
            while none of its frames is logged (an array left by a crash before its first
            event holds nothing).
        where
            The step named in errors.

        Raises
        ------
        SessionError
            If the frame's shape or dtype differs from the camera's logged frames, or the
            disk is full.
        """
        arr = self._array_for(camera, data, replace_ok, where)
        try:
            arr[slot] = data
            self._sync_chunk(camera, slot)
        except OSError as exc:
            if not is_disk_full(exc):
                raise
            # The chunk went in whole or not at all (zarr renames a finished temporary
            # file into place), and the frame is not logged: a resumed run captures it.
            raise session_error(
                where, f"{disk_full_cause(self._root)}; this frame was not stored", DISK_FULL_FIX
            ) from exc

    def read(self, camera: str, slot: int) -> NDArray[Any]:
        """The frame at ``slot`` of the camera's array (raises if the array is missing)."""
        return np.asarray(self._existing(camera)[slot])

    def read_slots(self, camera: str, slots: Sequence[int]) -> NDArray[Any]:
        """Frames at ``slots`` of the camera's array, stacked along a new first axis."""
        return np.asarray(self._existing(camera).oindex[np.asarray(slots, dtype=np.intp)])

    def check(self, camera: str, slot: int, sha256: str, shape: list[int], where: str) -> None:
        """Re-hash the frame at ``slot`` of the camera's array against its recorded hash.

        Raises
        ------
        SessionIntegrityError
            If the frame cannot be read, or its pixels or shape changed.
        """
        chunk = self.chunk_file(camera, slot)
        fix = (
            "recapture this step into a new session, or restore "
            f"{chunk.relative_to(self._root.parent)} from a backup"
        )
        try:
            data = self.read(camera, slot)
        except Exception as exc:
            raise session_error(
                where,
                f"the {camera} frame (slot {slot}) cannot be read ({exc})",
                fix,
                SessionIntegrityError,
            ) from exc
        if frame_sha256(data) != sha256 or list(data.shape) != shape:
            raise session_error(
                where,
                f"the stored {camera} frame (slot {slot}) changed since capture "
                f"(sha256 {frame_sha256(data)[:12]}, recorded {sha256[:12]})",
                fix,
                SessionIntegrityError,
            )

    def chunk_file(self, camera: str, slot: int) -> Path:
        """The file holding the frame at ``slot`` of the camera's array."""
        arr = self._existing(camera)
        key = arr.metadata.encode_chunk_key((slot,) + (0,) * (arr.ndim - 1))
        return self._root / arr.path / key

    def _existing(self, camera: str) -> zarr.Array:
        arr = self.array(camera)
        if arr is None:
            raise KeyError(f"{FRAMES_DIR}/{camera} does not exist")
        return arr

    def _array_for(
        self, camera: str, data: NDArray[Any], replace_ok: bool, where: str
    ) -> zarr.Array:
        shape = (len(self._steps[camera]), *data.shape)
        arr = self.array(camera)
        if arr is not None and (arr.shape == shape and arr.dtype == data.dtype):
            return arr
        if arr is not None and not replace_ok:
            raise session_error(
                where,
                f"frame is {data.dtype} {data.shape}, but the {camera} frames stored "
                f"so far are {arr.dtype} {arr.shape[1:]}",
                "keep the camera's resolution, binning and pixel format fixed for the "
                "whole session, or start a new session",
            )
        arr = self._group.create_array(
            camera,
            shape=shape,
            chunks=(1, *data.shape),
            dtype=data.dtype,
            fill_value=0,
            compressors=FRAME_CODEC,
            attributes={"camera": camera, "steps": self._steps[camera]},
            config={"write_empty_chunks": True},
            overwrite=True,
        )
        # Its folders are synced with the first chunk (see _sync_chunk).
        fsync_file(self._root / camera / "zarr.json")
        self._arrays[camera] = arr
        return arr

    def _sync_chunk(self, camera: str, slot: int) -> None:
        # Zarr writes chunks atomically (temp + rename) but does not fsync them.
        chunk = self.chunk_file(camera, slot)
        fsync_file(chunk)
        for folder in chunk.parents:
            fsync_dir(folder)
            if folder == self._root:
                break
