"""The MAT v5 writer: streamed variables read back by scipy exactly."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from scipy.io import loadmat

from sassi_bench.errors import ProcedureError
from sassi_bench.export.matfile import BandStream, write_mat


def _stream(cube: np.ndarray) -> BandStream:
    return BandStream(cube.shape, cube.dtype, lambda: (cube[..., t] for t in range(cube.shape[2])))


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.uint8, np.uint16, np.int32])
def test_round_trip(tmp_path, dtype):
    rng = np.random.default_rng(0)
    # Odd sizes: the data part needs padding to 8 bytes.
    cube = (rng.random((5, 7, 3)) * 200).astype(dtype)
    path = write_mat(
        tmp_path / "a.mat",
        {"small": np.arange(3.0), "text": "v0001", "cube": _stream(cube), "b": _stream(cube)},
    )
    mat = loadmat(path)
    for name in ("cube", "b"):
        assert mat[name].dtype == cube.dtype
        np.testing.assert_array_equal(mat[name], cube)
    np.testing.assert_array_equal(mat["small"], [[0.0, 1.0, 2.0]])
    assert str(mat["text"][0]) == "v0001"
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left behind


def test_refusals(tmp_path):
    cube = np.zeros((2, 2, 2), np.float32)
    write_mat(tmp_path / "a.mat", {"cube": _stream(cube)})
    with pytest.raises(ProcedureError, match="never overwritten"):
        write_mat(tmp_path / "a.mat", {"cube": _stream(cube)})
    huge = BandStream((2048, 2048, 200), np.float32, lambda: iter(()))
    with pytest.raises(ProcedureError, match="fewer wavelength bands"):
        write_mat(tmp_path / "b.mat", {"huge": huge})
    short = BandStream((2, 2, 3), np.float32, lambda: iter([cube[..., 0]]))
    with pytest.raises(ProcedureError, match="1 planes were given for a declared 3"):
        write_mat(tmp_path / "c.mat", {"short": short})
    with pytest.raises(ProcedureError, match="not a MATLAB name"):
        write_mat(tmp_path / "d.mat", {"2x": np.zeros(2)})
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mat"]


def test_every_variable_is_stored_compressed(tmp_path):
    """Each variable is one miCOMPRESSED element (type 15) that scipy reads back: a
    smooth table shrinks well below its raw size, at any zlib level."""
    rows = np.linspace(0.0, 400.0, 256 * 320 * 4, dtype=np.float32).reshape(256, 320, 4)
    rows = np.rint(rows * 64) / 64  # positions rounded to 1/64 px, as the export stores them
    sizes = {}
    for level in (1, 6):
        path = write_mat(
            tmp_path / f"l{level}.mat",
            {"wavelengths": np.arange(4.0), "calibstack_row": _stream(rows)},
            compression_level=level,
        )
        data = path.read_bytes()
        offset, types = 128, []
        while offset < len(data):
            mtype, nbytes = struct.unpack_from("<II", data, offset)
            types.append(mtype)
            offset += 8 + nbytes
        assert types == [15, 15]  # miCOMPRESSED, both the small and the streamed variable
        np.testing.assert_array_equal(loadmat(path)["calibstack_row"], rows)
        sizes[level] = len(data)
    assert sizes[6] <= sizes[1] < 0.25 * rows.nbytes
