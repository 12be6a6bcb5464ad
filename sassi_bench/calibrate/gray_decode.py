"""Decode Gray-code frames into the SLM block each camera pixel sees.

Each SLM axis is coded in blocks of ``block`` px, every bit followed by its inverse: a
robust, coarse estimate (+-block/2) that picks the period of the phase-shifted fringes
(:mod:`sassi_bench.calibrate.phase_decode`). :class:`GrayAccumulator` decodes the bits as
their frames arrive (a capture, or a session read back frame by frame);
:func:`decode_gray` takes them stacked. Gray block ``k`` is centred on
``block * k + (block - 1) / 2`` (pixel centres at integers).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape, check_shape_equality
from sassi_bench.calibrate import _frame_kernels as _kernels
from sassi_bench.calibrate.frame_stacks import (
    dark_argument,
    dark_level,
    frame_stack,
    saturation_argument,
)
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["GrayAccumulator", "GrayDecode", "check_block", "decode_gray"]


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


class GrayAccumulator:
    """The Gray decode of one axis, built one bit (a frame and its inverse) at a time.

    Each pair is folded into a running code word, the smallest and second-smallest bit
    contrasts and a saturation mask, in one compiled pass over the two frames
    (:mod:`~sassi_bench.calibrate._frame_kernels`); the bits may come in any order and
    no frame is kept.

    Parameters
    ----------
    shape
        The frames' (H, W).
    bits
        Gray bits of the axis (bit 0 = most significant).
    block
        SLM pixels per code word.
    dark
        Dark frame (H, W) or scalar, subtracted before the contrast is formed.
    saturation_level
        Raw value at which the camera saturates (``None``: no test); pixels that reach it
        in any frame are marked in :attr:`clipped`.
    step
        The step named in errors.

    Examples
    --------
    >>> acc = GrayAccumulator((1, 2), bits=1, block=4)
    >>> acc.add(0, np.array([[10, 0]]), np.array([[0, 10]]))
    >>> acc.result().coord.tolist()
    [[5.5, 1.5]]
    """

    def __init__(
        self,
        shape: tuple[int, int],
        bits: int,
        block: int,
        *,
        dark: ArrayLike | None = None,
        saturation_level: float | None = None,
        step: str = "Gray decoding",
    ) -> None:
        check_block(block, step)
        self.shape, self.bits, self.block, self.step = tuple(shape), int(bits), block, step
        self.dark, self._dark_map = dark_argument(dark_level(dark, self.shape, step))
        self.saturation = saturation_argument(saturation_level)
        self.word = np.zeros(self.shape, dtype=np.int32)
        self.smallest = np.full(self.shape, np.inf, dtype=np.float32)
        self.second = np.full(self.shape, np.inf, dtype=np.float32)
        self.clipped = np.zeros(self.shape, dtype=bool)
        self.seen: set[int] = set()

    def add(self, bit: int, positive: ArrayLike, negative: ArrayLike) -> None:
        """Fold in Gray bit ``bit`` from its frame and its inverse's (raw, (H, W))."""
        pos, neg = np.asarray(positive), np.asarray(negative)
        fix = "pass one frame of every bit and one of its inverse, of the frames' shape"
        for name, frame in (("positive frame", pos), ("negative frame", neg)):
            check_shape(frame, self.shape, step=self.step, name=name, fix=fix)
        if not 0 <= bit < self.bits or bit in self.seen:
            raise ProcedureError(
                step_error(self.step, f"Gray bit {bit} given twice or not one of {self.bits}", fix)
            )
        self.seen.add(bit)
        mask = np.int32(1 << (self.bits - 1 - bit))
        _kernels.gray_pair(
            pos, neg, self.dark, self._dark_map, mask, self.word, self.smallest, self.second,
            self.clipped, self.saturation,
        )  # fmt: skip

    def result(self, min_margin: float = 0.2) -> GrayDecode:
        """The decode of every bit given so far (:class:`GrayDecode`)."""
        index = _kernels.gray_index(self.word, self.bits)
        coord = self.block * index + (self.block - 1) / 2.0
        return GrayDecode(coord, self.smallest, self.second, self.smallest >= min_margin)


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
    accumulator = GrayAccumulator(pos.shape[1:], pos.shape[0], block, dark=dark, step=step)
    for bit, (pos_raw, neg_raw) in enumerate(zip(pos, neg, strict=True)):
        accumulator.add(bit, pos_raw, neg_raw)
    return accumulator.result(min_margin)
