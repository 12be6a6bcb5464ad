"""Decode Gray-code frames into the SLM block each camera pixel sees.

Each SLM axis is coded in blocks of ``block`` px, every bit followed by its inverse: a
robust, coarse estimate (+-block/2) that picks the period of the phase-shifted fringes
(:mod:`sassi_bench.calibrate.phase_decode`). Gray block ``k`` is centred on
``block * k + (block - 1) / 2`` (pixel centres at integers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape_equality
from sassi_bench.calibrate.frame_stacks import dark_level, frame_stack, subtract_dark
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["GrayDecode", "check_block", "decode_gray"]


@dataclass(frozen=True, eq=False)
class GrayDecode:
    """The decoded Gray block of every camera pixel.

    Attributes
    ----------
    coord
        ``block * index + (block - 1) / 2`` (H, W): the centre of the decoded block.
    margin
        The smallest bit contrast ``|pos - neg| / (pos + neg)`` of each pixel
        (H, W; 0 = undecidable, 1 = perfect).
    second_margin
        The second-smallest bit contrast (H, W). A pixel on a block boundary has one
        undecidable bit, yet either neighbouring block is a fine coarse estimate for
        phase unwrapping; a second weak bit makes the block ambiguous.
    valid
        ``margin >= min_margin`` (H, W).
    """

    coord: NDArray[np.float64]
    margin: NDArray[np.float32]
    second_margin: NDArray[np.float32]
    valid: NDArray[np.bool_]


def check_block(block: int, step: str) -> None:
    """Refuse a Gray block size that is not a positive integer.

    Examples
    --------
    >>> check_block(8, "Gray decoding")
    >>> check_block(0, "Gray decoding")  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: Gray decoding: block 0 is not a positive integer. Fix: ...
    """
    if isinstance(block, bool) or not isinstance(block, (int, np.integer)) or block < 1:
        raise ProcedureError(
            step_error(step, f"block {block!r} is not a positive integer", "use e.g. block=8")
        )


def decode_gray(
    positive: ArrayLike,
    negative: ArrayLike,
    block: int,
    min_margin: float = 0.2,
    *,
    dark: ArrayLike | None = None,
) -> GrayDecode:
    """Decode Gray-code frames (every bit with its inverse) into block-centre coordinates.

    Parameters
    ----------
    positive, negative
        Frames (bits, H, W) of the Gray bits (bit 0 = most significant) and of their
        inverse patterns.
    block
        SLM pixels per code word.
    min_margin
        Smallest acceptable bit contrast ``|pos - neg| / (pos + neg)``.
    dark
        Dark frame (H, W) or scalar, subtracted before the contrast is formed.

    Returns
    -------
    GrayDecode
        Block centres, the smallest and second-smallest bit contrasts and
        ``valid = margin >= min_margin``. Pixels on a block boundary have one
        undecidable bit and are not valid here, though either neighbouring block is a
        fine coarse estimate (:func:`~sassi_bench.calibrate.structured_light.decode_axis`
        allows one such bit).

    Examples
    --------
    >>> from sassi_bench.acquire.patterns import gray_bit_count, gray_pattern
    >>> bits = range(gray_bit_count(32, 4))
    >>> pos = np.stack([gray_pattern((1, 32), "x", b, 4) for b in bits])
    >>> neg = np.stack([gray_pattern((1, 32), "x", b, 4, inverse=True) for b in bits])
    >>> gray = decode_gray(pos, neg, block=4)
    >>> gray.coord[0, :6].tolist(), bool(gray.valid.all())
    ([1.5, 1.5, 1.5, 1.5, 5.5, 5.5], True)
    """
    step = "Gray decoding"
    pos = frame_stack(positive, step, "positive")
    neg = frame_stack(negative, step, "negative")
    check_shape_equality(
        pos,
        neg,
        step=step,
        names=("positive frames", "negative frames"),
        fix="pass one inverse frame per Gray bit, in the same order",
    )
    check_block(block, step)
    dark_arr = dark_level(dark, pos.shape[1:], step)
    shape = pos.shape[1:]
    index = np.zeros(shape, dtype=np.int64)
    binary = np.zeros(shape, dtype=bool)
    smallest = np.full(shape, np.inf, dtype=np.float32)
    second = np.full(shape, np.inf, dtype=np.float32)
    for pos_raw, neg_raw in zip(pos, neg, strict=True):
        on, off = subtract_dark(pos_raw, dark_arr), subtract_dark(neg_raw, dark_arr)
        total = on + off
        contrast = np.abs(on - off) / np.where(total > 0, total, np.float32(np.inf))
        # Binary bit b is the XOR of Gray bits 0..b (most significant first).
        binary ^= on > off
        index = (index << 1) | binary
        second = np.minimum(second, np.maximum(smallest, contrast))
        smallest = np.minimum(smallest, contrast)
    coord = block * index + (block - 1) / 2.0
    return GrayDecode(coord, smallest, second, smallest >= min_margin)
