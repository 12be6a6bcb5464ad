"""SLM patterns, described by small JSON-compatible dictionaries.

A capture plan stores each frame's pattern as a *descriptor* (``{"kind": "gray", ...}``)
rather than as pixels: sessions stay small, and analysis code regenerates exactly the
pattern that was shown. :func:`render_pattern` turns a descriptor into a uint8 image
(255 = fully open) with the renderer that :data:`PATTERN_RENDERERS` holds for its kind.

Kinds (:data:`PATTERN_RENDERERS`), with their keys:

``blank``
    all closed
``full``
    all open
``uniform``
    ``level``: one grey level everywhere
``gray``
    ``axis`` ("x" columns or "y" rows), ``bit`` (0 = most significant), ``block`` (px
    per code word), ``inverse``
``periodic``
    ``axis``, ``profile`` (grey levels of one period), ``shift`` (px): pixel ``p`` along
    the axis shows ``profile[(p - shift) % P]``
``lines``
    ``axis``, ``offset``, ``spacing``, ``width`` (px)
``pinholes``
    ``pitch`` [px_x, px_y], ``offset`` [x, y]
``pixels``
    ``rows``, ``cols``: the open pixels, listed one by one in row-major order (an
    adaptive snapshot mask, or any mask a user supplies; :func:`pixels_descriptor` makes
    one)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench._shared.arrays import check_ndim, check_shape_equality
from sassi_bench.errors import ProcedureError, did_you_mean, step_error

__all__ = [
    "PATTERN_RENDERERS",
    "PatternRenderer",
    "gray_bit_count",
    "gray_code",
    "gray_pattern",
    "lines_pattern",
    "open_pixels",
    "periodic_pattern",
    "pinhole_pattern",
    "pixels_descriptor",
    "render_pattern",
]


def gray_code(index: NDArray[np.integer]) -> NDArray[np.integer]:
    """Binary-reflected Gray code of non-negative integers.

    Examples
    --------
    >>> gray_code(np.arange(4)).tolist()
    [0, 1, 3, 2]
    """
    index = np.asarray(index)
    return index ^ (index >> 1)


def gray_bit_count(length: int, block: int) -> int:
    """Number of Gray-code bits needed to label ``length`` pixels in blocks of ``block``.

    Examples
    --------
    >>> gray_bit_count(640, 8), gray_bit_count(1920, 8)
    (7, 8)
    """
    blocks = -(-length // block)
    return max(1, int(np.ceil(np.log2(blocks))))


def _axis_shape(shape: tuple[int, int], axis: str) -> int:
    if axis not in ("x", "y"):
        raise ProcedureError(
            step_error("pattern", f"axis {axis!r} is not 'x' or 'y'", "use 'x' or 'y'")
        )
    return shape[1] if axis == "x" else shape[0]


def _broadcast(profile: NDArray[np.uint8], shape: tuple[int, int], axis: str) -> NDArray[np.uint8]:
    if axis == "x":
        return np.ascontiguousarray(np.broadcast_to(profile[None, :], shape))
    return np.ascontiguousarray(np.broadcast_to(profile[:, None], shape))


def gray_pattern(
    shape: tuple[int, int], axis: str, bit: int, block: int, inverse: bool = False
) -> NDArray[np.uint8]:
    """Bit ``bit`` (0 = most significant) of the Gray code of each pixel's block.

    Examples
    --------
    >>> gray_pattern((1, 8), "x", bit=0, block=2)[0].tolist()
    [0, 0, 0, 0, 255, 255, 255, 255]
    """
    length = _axis_shape(shape, axis)
    bits = gray_bit_count(length, block)
    if not 0 <= bit < bits:
        raise ProcedureError(
            step_error("pattern", f"Gray bit {bit} out of range", f"use 0..{bits - 1}")
        )
    code = gray_code(np.arange(length) // block)
    on = (code >> (bits - 1 - bit)) & 1
    profile = np.where(on.astype(bool) != inverse, 255, 0).astype(np.uint8)
    return _broadcast(profile, shape, axis)


def periodic_pattern(
    shape: tuple[int, int], axis: str, profile: NDArray[np.integer], shift: int
) -> NDArray[np.uint8]:
    """A 1-D periodic grey-level profile repeated along ``axis`` and shifted by ``shift``.

    Examples
    --------
    >>> periodic_pattern((1, 6), "x", np.array([0, 100, 200]), shift=1)[0].tolist()
    [200, 0, 100, 200, 0, 100]
    """
    profile = np.asarray(profile)
    if profile.ndim != 1 or profile.size < 2 or profile.min() < 0 or profile.max() > 255:
        raise ProcedureError(
            step_error(
                "pattern", "periodic profile must be 1-D grey levels 0..255", "check the plan"
            )
        )
    length = _axis_shape(shape, axis)
    levels = profile.astype(np.uint8)[(np.arange(length) - int(shift)) % profile.size]
    return _broadcast(levels, shape, axis)


def lines_pattern(
    shape: tuple[int, int], axis: str, offset: int, spacing: int, width: int = 1
) -> NDArray[np.uint8]:
    """Open lines: columns (axis "x") or rows (axis "y") at ``offset + k * spacing``.

    Examples
    --------
    >>> lines_pattern((1, 10), "x", offset=1, spacing=4)[0].tolist()
    [0, 255, 0, 0, 0, 255, 0, 0, 0, 255]
    """
    length = _axis_shape(shape, axis)
    pos = np.arange(length)
    on = ((pos - offset) % spacing < width) & (pos >= offset)
    return _broadcast(np.where(on, 255, 0).astype(np.uint8), shape, axis)


def pinhole_pattern(
    shape: tuple[int, int], pitch: tuple[int, int] = (100, 5), offset: tuple[int, int] = (0, 0)
) -> NDArray[np.uint8]:
    """Single open pixels on a grid, ``pitch`` = (horizontal, vertical) apart.

    Examples
    --------
    >>> int((pinhole_pattern((10, 12), pitch=(6, 5)) > 0).sum())
    4
    """
    out = np.zeros(shape, dtype=np.uint8)
    out[offset[1] :: pitch[1], offset[0] :: pitch[0]] = 255
    return out


def pixels_descriptor(mask: NDArray[np.bool_]) -> dict[str, Any]:
    """The ``pixels`` descriptor of a boolean mask: its open pixels, row-major.

    It stores the mask exactly, so a session records what the SLM showed and
    :func:`render_pattern` gives the same mask back.

    Examples
    --------
    >>> mask = np.zeros((3, 4), bool)
    >>> mask[0, 3] = mask[2, 1] = True
    >>> d = pixels_descriptor(mask)
    >>> d
    {'kind': 'pixels', 'rows': [0, 2], 'cols': [3, 1]}
    >>> bool(np.array_equal(render_pattern(d, (3, 4)) > 0, mask))
    True
    """
    mask = np.asarray(mask)
    check_ndim(mask, 2, step="pattern", name="the mask", fix="pass (H, W)")
    rows, cols = np.nonzero(mask)
    return {"kind": "pixels", "rows": rows.tolist(), "cols": cols.tolist()}


def _pixel_list(
    descriptor: Mapping[str, Any], shape: tuple[int, int]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    rows = np.asarray(descriptor["rows"], dtype=np.intp)
    cols = np.asarray(descriptor["cols"], dtype=np.intp)
    fix = "list one row and one column per open pixel"
    check_ndim(rows, 1, step="pattern", name="pixels.rows", fix=fix)
    check_shape_equality(rows, cols, step="pattern", names=("pixels.rows", "pixels.cols"), fix=fix)
    if rows.size and (
        rows.min() < 0 or cols.min() < 0 or rows.max() >= shape[0] or cols.max() >= shape[1]
    ):
        raise ProcedureError(
            step_error(
                "pattern",
                f"pixels: an open pixel lies outside the {shape[1]}x{shape[0]} SLM",
                "use rows 0..H-1 and columns 0..W-1 of this SLM",
            )
        )
    order = np.lexsort((cols, rows))
    return rows[order], cols[order]


def open_pixels(
    descriptor: Mapping[str, Any], shape: tuple[int, int]
) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """(rows, cols) of the open (non-zero) pixels of a pattern, in row-major order.

    Pinhole grids are enumerated directly, without rendering the whole SLM.

    Examples
    --------
    >>> rows, cols = open_pixels({"kind": "pinholes", "pitch": [6, 5], "offset": [1, 2]}, (10, 12))
    >>> rows.tolist(), cols.tolist()
    ([2, 2, 7, 7], [1, 7, 1, 7])
    """
    if descriptor.get("kind") == "pinholes":
        px, py = (int(p) for p in descriptor["pitch"])
        ox, oy = (int(o) for o in descriptor.get("offset", (0, 0)))
        rows, cols = np.meshgrid(
            np.arange(oy, shape[0], py), np.arange(ox, shape[1], px), indexing="ij"
        )
        return rows.ravel(), cols.ravel()
    if descriptor.get("kind") == "pixels":
        return _pixel_list(descriptor, shape)
    return np.nonzero(render_pattern(descriptor, shape))


def _render_blank(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    return np.zeros(shape, dtype=np.uint8)


def _render_full(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    return np.full(shape, 255, dtype=np.uint8)


def _render_uniform(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    return np.full(shape, int(descriptor["level"]), dtype=np.uint8)


def _render_gray(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    return gray_pattern(
        shape,
        descriptor["axis"],
        int(descriptor["bit"]),
        int(descriptor["block"]),
        bool(descriptor["inverse"]),
    )


def _render_periodic(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    profile = np.asarray(descriptor["profile"])
    return periodic_pattern(shape, descriptor["axis"], profile, int(descriptor["shift"]))


def _render_lines(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    return lines_pattern(
        shape,
        descriptor["axis"],
        int(descriptor["offset"]),
        int(descriptor["spacing"]),
        int(descriptor.get("width", 1)),
    )


def _render_pinholes(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    offset = tuple(descriptor.get("offset", (0, 0)))
    return pinhole_pattern(shape, tuple(descriptor["pitch"]), offset)


def _render_pixels(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    out = np.zeros(shape, dtype=np.uint8)
    out[_pixel_list(descriptor, shape)] = 255
    return out


PatternRenderer = Callable[[Mapping[str, Any], tuple[int, int]], NDArray[np.uint8]]

PATTERN_RENDERERS: Mapping[str, PatternRenderer] = MappingProxyType(
    {
        "blank": _render_blank,
        "full": _render_full,
        "uniform": _render_uniform,
        "gray": _render_gray,
        "periodic": _render_periodic,
        "lines": _render_lines,
        "pinholes": _render_pinholes,
        "pixels": _render_pixels,
    }
)
"""Renderer of every pattern kind: ``renderer(descriptor, shape)`` -> uint8 image.

The kinds and their descriptor keys are listed in the module docstring; sessions store
descriptors by kind, so the mapping is read-only.

Examples
--------
>>> sorted(PATTERN_RENDERERS)[:3]
['blank', 'full', 'gray']
"""


def render_pattern(descriptor: Mapping[str, Any], shape: tuple[int, int]) -> NDArray[np.uint8]:
    """Render a pattern descriptor (see the module docstring) for an SLM of ``shape``.

    Parameters
    ----------
    descriptor
        ``{"kind": <a key of PATTERN_RENDERERS>, ...}`` with that kind's keys.
    shape
        The SLM's (height, width).

    Returns
    -------
    ndarray
        uint8 image of ``shape``, 255 = fully open.

    Raises
    ------
    ProcedureError
        For an unknown kind (naming the closest known one) or bad parameters;
        ``KeyError`` for a missing descriptor key.

    Examples
    --------
    >>> render_pattern({"kind": "uniform", "level": 7}, (2, 3)).tolist()
    [[7, 7, 7], [7, 7, 7]]
    >>> render_pattern({"kind": "pinhole"}, (2, 3))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: pattern: ... 'pinhole' (did you mean 'pinholes'?). Fix: ...
    """
    kind = descriptor.get("kind")
    renderer = PATTERN_RENDERERS.get(kind) if isinstance(kind, str) else None
    if renderer is None:
        *others, last = PATTERN_RENDERERS
        raise ProcedureError(
            step_error(
                "pattern",
                f"unknown pattern kind {kind!r}{did_you_mean(kind, PATTERN_RENDERERS)}",
                f"use {', '.join(others)} or {last}",
            )
        )
    return renderer(descriptor, shape)
