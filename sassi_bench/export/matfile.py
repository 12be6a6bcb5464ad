"""MATLAB v5 (``.mat``) files whose large arrays are written one band at a time.

Small variables go through :func:`scipy.io.savemat`. Camera-sized lookup tables do not:
scipy builds each compressed variable whole in memory (the array in Fortran order, its
uncompressed stream and a copy of that, then the compressed bytes), about four times the
array, which for a (2048, 2048, 68) float32 table is 4.6 GB on top of the table itself.
:class:`BandStream` instead describes a 3-D array by a function that yields its
``(H, W)`` planes; :func:`write_mat` compresses plane after plane into one ``miCOMPRESSED``
element, so memory stays at one plane and the full table never exists in memory.

The v5 layout written here (MathWorks, "MAT-File Format", level 5): a 128-byte header
(written by scipy), then per variable an ``miCOMPRESSED`` tag and a zlib stream holding an
``miMATRIX`` element: array flags (class), dimensions (int32), name (int8) and the real
part, column-major. A variable may hold at most 2**31 - 1 bytes of data: the limit MATLAB
documents for v5/v7 files (larger ones need the HDF5-based v7.3, which
:func:`scipy.io.loadmat` cannot read).
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike
from scipy.io import savemat

from sassi_bench._shared.arrays import check_shape
from sassi_bench._shared.atomic import atomic_path
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["MAX_VARIABLE_BYTES", "BandStream", "write_mat"]

#: The largest data part of one variable a v5 MAT file may hold (MATLAB's 2 GB limit).
MAX_VARIABLE_BYTES = 2**31 - 1

_MI_INT8, _MI_INT32, _MI_UINT32, _MI_MATRIX, _MI_COMPRESSED = 1, 5, 6, 14, 15
# numpy dtype -> (MATLAB array class, v5 data type of the elements)
_CLASSES = {
    np.dtype(np.float64): (6, 9),
    np.dtype(np.float32): (7, 7),
    np.dtype(np.int8): (8, 1),
    np.dtype(np.uint8): (9, 2),
    np.dtype(np.int16): (10, 3),
    np.dtype(np.uint16): (11, 4),
    np.dtype(np.int32): (12, 5),
    np.dtype(np.uint32): (13, 6),
}


@dataclass(frozen=True)
class BandStream:
    """A 3-D ``(H, W, T)`` array given plane by plane: ``planes()`` yields ``T`` arrays
    ``(H, W)``, in order, each converted to ``dtype``.

    Examples
    --------
    >>> cube = np.arange(24, dtype=np.float32).reshape(2, 3, 4)
    >>> stream = BandStream((2, 3, 4), np.float32, lambda: (cube[..., t] for t in range(4)))
    >>> stream.nbytes
    96
    """

    shape: tuple[int, int, int]
    dtype: Any
    planes: Callable[[], Iterable[ArrayLike]]

    @property
    def nbytes(self) -> int:
        """Size of the data part in bytes."""
        return int(np.prod(self.shape)) * np.dtype(self.dtype).itemsize


def _element(mtype: int, payload: bytes) -> bytes:
    """A v5 data element: tag (type, byte count), payload, zero padding to 8 bytes."""
    return struct.pack("<II", mtype, len(payload)) + payload + bytes(-len(payload) % 8)


def _matrix_header(name: str, shape: tuple[int, ...], dtype: np.dtype) -> tuple[bytes, int]:
    """The start of an ``miMATRIX`` element up to the real part's tag, and the element's
    total size (its tag included)."""
    mx_class, mi_type = _CLASSES[dtype]
    flags = _element(_MI_UINT32, struct.pack("<II", mx_class, 0))
    dims = _element(_MI_INT32, struct.pack(f"<{len(shape)}i", *shape))
    label = _element(_MI_INT8, name.encode("ascii"))
    nbytes = int(np.prod(shape)) * dtype.itemsize
    content = len(flags) + len(dims) + len(label) + 8 + nbytes + (-nbytes % 8)
    head = struct.pack("<II", _MI_MATRIX, content) + flags + dims + label
    return head + struct.pack("<II", mi_type, nbytes), 8 + content


def _check_variable(name: str, shape: tuple[int, ...], dtype: np.dtype) -> None:
    where = f"MAT file variable {name!r}"
    if not name.isidentifier() or not name.isascii() or name.startswith("_"):
        raise ProcedureError(
            step_error(where, "is not a MATLAB name", "use letters, digits and '_'")
        )
    if dtype not in _CLASSES:
        raise ProcedureError(
            step_error(where, f"has dtype {dtype}", "use float32/64 or (u)int8/16/32")
        )
    nbytes = int(np.prod(shape)) * dtype.itemsize
    if nbytes > MAX_VARIABLE_BYTES:
        raise ProcedureError(
            step_error(
                where,
                f"{shape} {dtype} is {nbytes / 2**30:.2f} GiB, over the 2 GiB a v5 MAT "
                "variable may hold",
                "export fewer wavelength bands",
            )
        )


def _write_stream(fh, name: str, stream: BandStream, level: int) -> None:
    dtype = np.dtype(stream.dtype)
    height, width, bands = stream.shape
    _check_variable(name, stream.shape, dtype)
    head, total = _matrix_header(name, stream.shape, dtype)
    tag_at = fh.tell()
    fh.write(struct.pack("<II", _MI_COMPRESSED, 0))  # byte count patched below
    packer = zlib.compressobj(level)
    written = fh.write(packer.compress(head))
    count = 0
    for plane in stream.planes():
        data = np.asarray(plane, dtype=dtype)
        check_shape(
            data,
            (height, width),
            step=f"MAT file variable {name!r}",
            name=f"plane {count}",
            fix="yield (H, W) planes of the declared shape",
        )
        # Column-major: plane t of an (H, W, T) array is one contiguous block.
        written += fh.write(packer.compress(data.tobytes(order="F")))
        count += 1
    if count != bands:
        raise ProcedureError(
            step_error(
                f"MAT file variable {name!r}",
                f"{count} planes were given for a declared {bands}",
                "yield exactly one plane per band",
            )
        )
    padding = -stream.nbytes % 8
    written += fh.write(packer.compress(bytes(padding)) + packer.flush())
    assert total == len(head) + stream.nbytes + padding  # the header's sizes are consistent
    end = fh.tell()
    fh.seek(tag_at + 4)
    fh.write(struct.pack("<I", written))
    fh.seek(end)


def write_mat(
    path: str | os.PathLike[str],
    variables: Mapping[str, ArrayLike | str | BandStream],
    *,
    compression_level: int = 1,
) -> Path:
    """Write a MATLAB v5 file: ordinary values with scipy, :class:`BandStream` values
    plane by plane (every variable compressed).

    The file is written beside ``path`` under a temporary name and renamed into place;
    an existing file is never overwritten.

    Parameters
    ----------
    path
        The ``.mat`` file to create.
    variables
        Name -> value: arrays, strings, numbers (written by :func:`scipy.io.savemat`,
        1-D arrays as rows) or :class:`BandStream`.
    compression_level
        zlib level of the streamed variables, 0-9. Level 1 is the default: on float32
        lookup tables it compresses at twice the speed of level 6 to within 1 % of its
        size (random low mantissa bits do not compress at any level).

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> from scipy.io import loadmat
    >>> folder = Path(tempfile.mkdtemp())
    >>> cube = np.arange(24, dtype=np.float32).reshape(2, 3, 4)
    >>> stream = BandStream(cube.shape, np.float32, lambda: (cube[..., t] for t in range(4)))
    >>> out = write_mat(folder / "a.mat", {"note": "hi", "cube": stream})
    >>> back = loadmat(out)
    >>> bool(np.array_equal(back["cube"], cube)), str(back["note"][0])
    (True, 'hi')
    """
    path = Path(path)
    if path.exists():
        raise ProcedureError(
            step_error(
                "MAT file export",
                f"{path} already exists (exports are never overwritten)",
                "choose another output folder, or delete the old file first",
            )
        )
    small = {k: v for k, v in variables.items() if not isinstance(v, BandStream)}
    streams = {k: v for k, v in variables.items() if isinstance(v, BandStream)}
    for name, value in small.items():
        if not isinstance(value, str):
            _check_variable(name, np.shape(value), np.asarray(value).dtype)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        with atomic_path(path, overwrite=False) as temporary, open(temporary, "xb") as fh:
            # savemat writes the 128-byte header first (the stream is at position 0).
            savemat(fh, small, do_compression=True, oned_as="row")
            for name, stream in streams.items():
                _write_stream(fh, name, stream, compression_level)
    except FileExistsError:
        raise ProcedureError(
            step_error(
                "MAT file export",
                f"{path} appeared while it was being written",
                "export to a folder no other process writes to",
            )
        ) from None
    return path
