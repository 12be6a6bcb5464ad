"""``frames.zarr/``: a session's frames, one Zarr v3 array per camera, one chunk per frame.

A camera's array is ``(n, H, W)`` (``spectral``) or ``(n, H, W, 3)`` (``guide``), with one
slot per plan step of that camera (a step's slot is its rank among them). It is created
when the camera's first frame is written, with that frame's shape and dtype; later frames
must match. Chunks are compressed with :data:`FRAME_CODEC` and fsync'd, with every folder
up to the store, as soon as they are written.

Every read is checked against what the event log recorded when the frame was stored:
its shape and the checksum of its pixels (:func:`frame_checksum`, a 64-bit xxh3, many
times cheaper than the frame's SHA-256; frames logged before the checksum existed are
checked against their SHA-256). Zarr reads a chunk file
that is gone as its fill value and gives no sign of it: the checksum catches that, a
truncated or edited chunk, and a chunk that no longer decodes (:class:`FrameProblem`
says which).

Examples
--------
>>> import tempfile
>>> folder = Path(tempfile.mkdtemp())
>>> FrameStore.create(folder, {"session": "demo"})
>>> store = FrameStore(folder, {"spectral": [0, 1]})
>>> pixels = np.full((2, 3), 7, np.uint16)
>>> stored = store.write("spectral", 1, pixels, replace_ok=True, where="demo")
>>> record = {"shape": [2, 3], "sha256": frame_sha256(pixels),
...           "xxh3_64": frame_checksum(pixels), "stored_bytes": stored}
>>> store.read("spectral", 1, record).tolist(), store.array("guide") is None
([[7, 7, 7], [7, 7, 7]], True)
>>> store.chunk_file("spectral", 1).unlink()
>>> store.read("spectral", 1, record)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
sassi_bench.acquire.session.frames.FrameProblem: missing: its chunk file is gone ...
"""

from __future__ import annotations

import hashlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xxhash
import zarr
from numpy.typing import NDArray
from zarr.codecs import BloscCodec, BloscShuffle
from zarr.storage import LocalStore

from sassi_bench._shared.arrays import check_dtype_kind, check_shape
from sassi_bench._shared.atomic import fsync_dir, fsync_file
from sassi_bench._shared.disk import DISK_FULL_FIX, disk_full_cause, is_disk_full
from sassi_bench.acquire.session.errors import SessionError, session_error

__all__ = [
    "CHECKSUM_KEY",
    "FRAMES_DIR",
    "FRAME_CODEC",
    "STORED_BYTES_KEY",
    "FrameProblem",
    "FrameStore",
    "check_frame",
    "frame_checksum",
    "frame_sha256",
]

FRAMES_DIR = "frames.zarr"
#: The compressor of every frame chunk: zstd after a byte shuffle, which puts the 16-bit
#: pixels' high bytes (nearly constant) together: smaller and cheaper to encode than plain
#: zstd or a bit shuffle on noisy frames, and near what their noise leaves to a lossless
#: codec (``benchmarks/bench_codecs.py``; the figures:
#: ``docs/notes/2026-12-01-measured-in-code-comments.md``). Each array records its codec,
#: so frames written with an earlier one still read.
FRAME_CODEC = BloscCodec(cname="zstd", clevel=3, shuffle=BloscShuffle.shuffle)
#: The shape of a frame of each canonical camera: grey spectral, RGB guide.
_FRAME_SHAPES = {"spectral": ("H", "W"), "guide": ("H", "W", 3)}
#: The event key of a frame's read checksum (:func:`frame_checksum`).
CHECKSUM_KEY = "xxh3_64"
#: The event key of the size of a frame's chunk file as stored (a cheap check by ``stat``).
STORED_BYTES_KEY = "stored_bytes"


class FrameProblem(Exception):
    """A stored frame is not what was recorded: ``kind`` (``missing``, ``truncated``,
    ``unreadable``, ``changed``) and ``detail`` say how; ``slot`` which frame."""

    def __init__(self, kind: str, detail: str, slot: int = -1) -> None:
        super().__init__(f"{kind}: {detail}")
        self.kind, self.detail, self.slot = kind, detail, slot


def _pixel_bytes(data: NDArray[Any]) -> NDArray[Any]:
    """The frame's pixels as a C-ordered little-endian array (no copy when they are)."""
    arr = np.asarray(data)
    return np.ascontiguousarray(arr.astype(arr.dtype.newbyteorder("<"), copy=False))


def frame_sha256(data: NDArray[Any]) -> str:
    """SHA-256 (hex) of a frame's pixel bytes: C order, little-endian.

    Examples
    --------
    >>> frame_sha256(np.zeros((1, 1), np.uint16))[:12]
    '96a296d224f2'
    """
    return hashlib.sha256(_pixel_bytes(data).reshape(-1).view(np.uint8)).hexdigest()


def frame_checksum(data: NDArray[Any]) -> str:
    """The checksum every read of a stored frame is checked against: the 64-bit xxh3 hash
    (hex) of its pixel bytes, C order, little-endian.

    Not a cryptographic hash (the event's SHA-256 is the frame's identity): a fast one,
    so that checking each frame as it is read costs little beside decoding it (xxh3 hashes
    many times faster than SHA-256 or CRC-32:
    ``docs/notes/2026-12-01-measured-in-code-comments.md``); 64 bits leave a damaged frame
    one chance in 2**64 to pass.

    Examples
    --------
    >>> frame_checksum(np.zeros((1, 1), np.uint16))
    '3325230e1f285505'
    """
    return xxhash.xxh3_64_hexdigest(_pixel_bytes(data).reshape(-1).view(np.uint8))


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
    ) -> int:
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

        Returns
        -------
        int
            The size of the frame's chunk file as stored, in bytes.

        Raises
        ------
        SessionError
            If the frame's shape or dtype differs from the camera's logged frames, or the
            disk is full.
        """
        arr = self._array_for(camera, data, replace_ok, where)
        try:
            arr[slot] = data
            return self._sync_chunk(camera, slot)
        except OSError as exc:
            if not is_disk_full(exc):
                raise
            # The chunk went in whole or not at all (zarr renames a finished temporary
            # file into place), and the frame is not logged: a resumed run captures it.
            raise session_error(
                where, f"{disk_full_cause(self._root)}; this frame was not stored", DISK_FULL_FIX
            ) from exc

    def read(self, camera: str, slot: int, record: Mapping[str, Any]) -> NDArray[Any]:
        """The frame at ``slot`` of the camera's array, checked against ``record``.

        Parameters
        ----------
        camera, slot
            Which frame.
        record
            What its event recorded: ``shape``, and :data:`CHECKSUM_KEY` (else ``sha256``);
            :data:`STORED_BYTES_KEY` when known names a truncated chunk as such.

        Raises
        ------
        FrameProblem
            If the frame does not decode or is not the frame that was stored.
        KeyError
            If the camera's array does not exist.
        """
        arr = self._existing(camera)
        try:
            data = np.asarray(arr[slot])
        except Exception as exc:  # whatever the codec raises: the chunk does not decode
            raise self._undecodable(camera, slot, record, exc) from None
        self._check(camera, slot, data, record)
        return data

    def read_slots(
        self, camera: str, slots: Sequence[int], records: Sequence[Mapping[str, Any]]
    ) -> NDArray[Any]:
        """Frames at ``slots`` of the camera's array, stacked along a new first axis, each
        checked against its record (see :meth:`read`)."""
        arr = self._existing(camera)
        try:
            stack = np.asarray(arr.oindex[np.asarray(slots, dtype=np.intp)])
        except Exception:  # one chunk does not decode: find it
            for slot, record in zip(slots, records, strict=True):
                self.read(camera, slot, record)
            raise
        for frame, slot, record in zip(stack, slots, records, strict=True):
            self._check(camera, slot, frame, record)
        return stack

    def inspect(self, camera: str, slot: int, record: Mapping[str, Any]) -> FrameProblem | None:
        """What is wrong with a stored frame, read whole and checked against both its
        checksum and its SHA-256 (None: nothing)."""
        problem = self.quick_inspect(camera, slot, record)
        if problem is not None:
            return problem
        try:
            data = self.read(camera, slot, record)
        except FrameProblem as found:
            return found
        sha_ok = frame_sha256(data) == record["sha256"]
        sum_ok = CHECKSUM_KEY not in record or frame_checksum(data) == record[CHECKSUM_KEY]
        if sha_ok and sum_ok:
            return None
        if sha_ok or sum_ok:  # one recorded hash holds: the other is what was damaged
            wrong = "checksum" if sha_ok else "SHA-256"
            right = "SHA-256" if sha_ok else "checksum"
            return FrameProblem(
                "mislogged",
                f"its event in events.jsonl records another {wrong}, but its pixels match "
                f"the {right} recorded: the event line is damaged, not the frame",
                slot,
            )
        return FrameProblem(
            "changed",
            f"its pixels' SHA-256 is {frame_sha256(data)[:12]}, "
            f"{record['sha256'][:12]} was recorded at capture",
            slot,
        )

    def quick_inspect(
        self, camera: str, slot: int, record: Mapping[str, Any]
    ) -> FrameProblem | None:
        """What the file system alone shows is wrong with a stored frame (a chunk file
        gone, or of another size than stored), without reading it (None: nothing seen)."""
        try:
            chunk = self.chunk_file(camera, slot)
        except KeyError:
            return FrameProblem("missing", f"{FRAMES_DIR}/{camera} is gone", slot)
        try:
            size = chunk.stat().st_size
        except FileNotFoundError:
            return FrameProblem("missing", self._gone(chunk), slot)
        return self._size_problem(size, record, slot)

    def _check(self, camera: str, slot: int, data: NDArray[Any], record: Mapping[str, Any]) -> None:
        """Raise a :class:`FrameProblem` when ``data`` is not the frame ``record`` logged."""
        shape = list(record["shape"])
        if list(data.shape) != shape:
            raise FrameProblem(
                "changed", f"it is {list(data.shape)} pixels, {shape} were stored", slot
            )
        if CHECKSUM_KEY in record:
            if frame_checksum(data) == record[CHECKSUM_KEY]:
                return
            if frame_sha256(data) == record.get("sha256"):
                return  # the pixels are the frame stored; the logged checksum is damaged
            found = f"its pixels' checksum is {frame_checksum(data)}, {record[CHECKSUM_KEY]}"
        else:  # logged before the checksum existed: its SHA-256, the slower check
            if frame_sha256(data) == record["sha256"]:
                return
            found = f"its pixels' SHA-256 is {frame_sha256(data)[:12]}, {record['sha256'][:12]}"
        chunk = self.chunk_file(camera, slot)
        try:
            size = chunk.stat().st_size
        except FileNotFoundError:
            raise FrameProblem("missing", self._gone(chunk), slot) from None
        problem = self._size_problem(size, record, slot)
        if problem is not None:
            raise problem
        raise FrameProblem("changed", f"{found} was recorded at capture", slot)

    def _undecodable(
        self, camera: str, slot: int, record: Mapping[str, Any], exc: Exception
    ) -> FrameProblem:
        chunk = self.chunk_file(camera, slot)
        try:
            size = chunk.stat().st_size
        except FileNotFoundError:
            return FrameProblem("missing", self._gone(chunk), slot)
        problem = self._size_problem(size, record, slot)
        cause = f"{type(exc).__name__}: {exc}"
        if problem is not None:
            detail = f"{problem.detail}; it does not decode ({cause})"
            return FrameProblem(problem.kind, detail, slot)
        return FrameProblem("unreadable", f"its chunk file does not decode ({cause})", slot)

    @staticmethod
    def _gone(chunk: Path) -> str:
        return "its chunk file is gone (Zarr would read it as zeros)"

    @staticmethod
    def _size_problem(size: int, record: Mapping[str, Any], slot: int) -> FrameProblem | None:
        stored = record.get(STORED_BYTES_KEY)
        if stored is None or size == stored:
            return None
        kind = "truncated" if size < stored else "changed"
        return FrameProblem(kind, f"its chunk file is {size} bytes, {stored} were stored", slot)

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

    def _sync_chunk(self, camera: str, slot: int) -> int:
        """Fsync a written chunk and its folders up to the store; its size in bytes."""
        # Zarr writes chunks atomically (temp + rename) but does not fsync them.
        chunk = self.chunk_file(camera, slot)
        fsync_file(chunk)
        for folder in chunk.parents:
            fsync_dir(folder)
            if folder == self._root:
                break
        return chunk.stat().st_size
