"""The mask kernels' word-at-a-time scans against plain numpy."""

from __future__ import annotations

import numpy as np
import pytest

from sassi_bench.snapshot import _kernels


@pytest.mark.parametrize("shape", [(1, 1), (3, 7), (13, 931), (40, 64)])
def test_run_starts_and_label_runs_match_numpy(shape):
    rng = np.random.default_rng(shape[1])
    labels = (rng.integers(0, 4, shape) // 2 + np.arange(shape[1]) // 5).astype(np.int32)
    labels[0, : shape[1] // 2] = -1  # no superpixel: skipped
    flat = labels.ravel()
    change = np.ones(flat.size, bool)
    change[1:] = flat[1:] != flat[:-1]
    change[:: shape[1]] = True
    np.testing.assert_array_equal(_kernels.run_starts(flat, shape[1]), np.flatnonzero(change))
    n = int(labels.max()) + 1
    count, row_sum, col_sum, first, run_row, run_start, run_end = _kernels.label_runs(labels, n)
    rows, cols = np.indices(shape)
    inside = labels >= 0
    np.testing.assert_array_equal(count, np.bincount(labels[inside], minlength=n))
    np.testing.assert_array_equal(row_sum, np.bincount(labels[inside], rows[inside], n))
    np.testing.assert_array_equal(col_sum, np.bincount(labels[inside], cols[inside], n))
    for k in range(n):  # label k's runs cover exactly its pixels, by row then column
        painted = np.zeros(shape, bool)
        runs = range(first[k], first[k + 1])
        keys = [(run_row[j], run_start[j]) for j in runs]
        assert keys == sorted(keys)
        for j in runs:
            assert not painted[run_row[j], run_start[j] : run_end[j] + 1].any()
            painted[run_row[j], run_start[j] : run_end[j] + 1] = True
        np.testing.assert_array_equal(painted, labels == k)


def test_blocked_bits_and_byte_skipping_match_numpy():
    rng = np.random.default_rng(1)
    blocked = (rng.uniform(size=(9, 131)) < 0.3).astype(np.uint8)
    blocked[2] = 1
    bits = _kernels.blocked_bits(blocked)
    unpacked = np.unpackbits(bits.view(np.uint8), axis=1, bitorder="little")[:, :131]
    np.testing.assert_array_equal(unpacked, blocked)
    flat = blocked.ravel()
    words = _kernels.as_words(flat)
    for value in (0, 1):
        for start, stop in ((0, flat.size), (5, 400), (262, 300), (8, 8)):
            hits = np.flatnonzero(flat[start:stop] != value)
            expected = start + hits[0] if hits.size else stop
            assert _kernels.skip_bytes(flat, words, value, start, stop) == expected
    painted = np.zeros_like(bits)
    _kernels.paint_bits(painted, 1, 4, 60, 130)
    unpacked = np.unpackbits(painted.view(np.uint8), axis=1, bitorder="little")[:, :131]
    expected = np.zeros((9, 131), np.uint8)
    expected[1:4, 60:131] = 1
    np.testing.assert_array_equal(unpacked, expected)
