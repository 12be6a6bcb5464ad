"""Masks that keep the spacing rule: checking a given mask, uniform and random masks.

The rule is :class:`sassi_bench.bundle.MaskSpacing`'s: a pixel open at ``(u, v)`` forbids
other open pixels in rows ``v - pitch + 1 .. v + pitch - 1`` and columns
``u - left[v, u] .. u + right[v, u]``. Uniform and random masks with the same rule are the
baselines an adaptive mask is compared with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench._shared.arrays import check_shape
from sassi_bench.bundle import MaskSpacing
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.snapshot import _kernels

__all__ = ["check_mask", "mask_conflicts", "random_mask", "uniform_mask"]


def _as_mask(mask: ArrayLike, spacing: MaskSpacing, step: str) -> NDArray[np.bool_]:
    array = np.asarray(mask)
    check_shape(
        array,
        spacing.slm_shape,
        step=step,
        name="the mask",
        expected_for="the SLM",
        fix=f"pass a boolean {spacing.slm_shape} array (rows, columns of the SLM)",
    )
    if array.dtype != np.bool_:
        if array.dtype.kind not in "iuf" or not np.isin(array, (0, 1)).all():
            raise ProcedureError(
                step_error(
                    step,
                    f"the mask has dtype {array.dtype} and values other than 0 and 1",
                    "pass a boolean array (True = open)",
                )
            )
        array = array.astype(bool)
    return array


def mask_conflicts(mask: ArrayLike, spacing: MaskSpacing) -> NDArray[np.intp]:
    """Open pixels whose forbidden window holds another open pixel.

    Every violating pair has at least one member listed (both when each lies in the
    other's window). Counts come from an integral image of the mask, one lookup per open
    pixel.

    Parameters
    ----------
    mask
        ``(H, W)`` bool, True = open.
    spacing
        The rule (:meth:`CalibrationBundle.mask_spacing`).

    Returns
    -------
    ndarray
        ``(K, 2)`` (row, column) of the offending pixels, row-major order; empty if the
        mask keeps the rule.

    Examples
    --------
    >>> spacing = MaskSpacing(np.full((6, 20), 3), np.full((6, 20), 3), 2, 3.0, 3.0)
    >>> mask = np.zeros((6, 20), bool); mask[2, [4, 8, 10]] = True
    >>> mask_conflicts(mask, spacing).tolist()
    [[2, 8], [2, 10]]
    """
    mask = _as_mask(mask, spacing, "mask check")
    h, w = mask.shape
    rows, cols = np.nonzero(mask)
    integral = np.zeros((h + 1, w + 1), dtype=np.int32)
    np.cumsum(np.cumsum(mask, axis=0, dtype=np.int32), axis=1, out=integral[1:, 1:])
    p = spacing.pitch
    r0, r1 = np.maximum(rows - p + 1, 0), np.minimum(rows + p, h)
    c0 = np.maximum(cols - spacing.left[rows, cols], 0)
    c1 = np.minimum(cols + spacing.right[rows, cols] + 1, w)
    inside = integral[r1, c1] - integral[r0, c1] - integral[r1, c0] + integral[r0, c0]
    bad = inside > 1  # the pixel itself counts once
    return np.column_stack([rows[bad], cols[bad]])


def check_mask(mask: ArrayLike, spacing: MaskSpacing) -> NDArray[np.bool_]:
    """Check that a user-supplied mask keeps the spacing rule; return it as bool.

    Raises
    ------
    ProcedureError
        Naming how many open pixels violate the rule, the first few of them and the
        separation they need, when the mask has the wrong shape, is not boolean, is empty,
        or keeps open pixels closer than the rule allows.

    Examples
    --------
    >>> spacing = MaskSpacing(np.full((6, 20), 3), np.full((6, 20), 3), 2, 3.0, 3.0)
    >>> mask = np.zeros((6, 20), bool); mask[2, [4, 10]] = True
    >>> int(check_mask(mask, spacing).sum())
    2
    >>> mask[3, 6] = True
    >>> check_mask(mask, spacing)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: mask check: 2 of 3 open pixels have another ...
    """
    array = _as_mask(mask, spacing, "mask check")
    if not array.any():
        raise ProcedureError(
            step_error("mask check", "the mask opens no pixel", "open at least one SLM pixel")
        )
    bad = mask_conflicts(array, spacing)
    if bad.size:
        shown = ", ".join(f"(u={c}, v={r})" for r, c in bad[:5].tolist())
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        r, c = bad[0]
        raise ProcedureError(
            step_error(
                "mask check",
                f"{len(bad)} of {int(array.sum())} open pixels have another open pixel in "
                f"their forbidden window: {shown}{more} (e.g. (u={c}, v={r}) forbids columns "
                f"{c - spacing.left[r, c]}..{c + spacing.right[r, c]} in rows "
                f"{r - spacing.pitch + 1}..{r + spacing.pitch - 1}), so their streaks overlap",
                "space open pixels as the bundle's mask_spacing() says, or build the mask with "
                "adaptive_mask, uniform_mask or random_mask",
            )
        )
    return array


@dataclass
class MaskBuilder:
    """A mask being opened pixel by pixel under a spacing rule (compiled; see
    :mod:`sassi_bench.snapshot._kernels`)."""

    spacing: MaskSpacing
    blocked: NDArray[np.uint8]
    row_cols: NDArray[np.int32]
    row_count: NDArray[np.int32]
    mask: NDArray[np.bool_]

    @classmethod
    def empty(cls, spacing: MaskSpacing) -> MaskBuilder:
        h, w = spacing.slm_shape
        # Two open pixels of one row are more than `right` of the left one apart.
        narrowest = int(spacing.right[:, : max(w - 1, 1)].min()) + 1
        capacity = w // max(narrowest, 1) + 2
        return cls(
            spacing,
            np.zeros((h, w), np.uint8),
            np.empty((h, capacity), np.int32),
            np.zeros(h, np.int32),
            np.zeros((h, w), np.bool_),
        )

    @property
    def rule(self) -> tuple:
        s = self.spacing
        return (s.left, s.right, s.pitch)

    def fill(self, order: NDArray[np.intp] | None = None, limit: int | None = None) -> int:
        """Open every pixel (in raster order, or the flat indices of ``order``) that keeps
        the rule, at most ``limit``; returns how many were opened."""
        state = (self.blocked, self.row_cols, self.row_count, self.mask)
        if order is None:
            return int(_kernels.fill_raster(*self.rule, *state))
        cap = np.iinfo(np.int64).max if limit is None else int(limit)
        return int(_kernels.fill_in_order(np.asarray(order, np.int64), cap, *self.rule, *state))


def uniform_mask(spacing: MaskSpacing, offset: tuple[int, int] = (0, 0)) -> NDArray[np.bool_]:
    """A regular lattice that keeps the rule: every ``pitch``-th row and every
    :attr:`MaskSpacing.uniform_step`-th column, from ``offset`` (row, column).

    Examples
    --------
    >>> spacing = MaskSpacing(np.full((6, 20), 3), np.full((6, 20), 3), 2, 3.0, 3.0)
    >>> np.argwhere(uniform_mask(spacing, (1, 2)))[:3].tolist()
    [[1, 2], [1, 6], [1, 10]]
    """
    h, w = spacing.slm_shape
    mask = np.zeros((h, w), dtype=bool)
    mask[
        offset[0] % spacing.pitch :: spacing.pitch,
        offset[1] % spacing.uniform_step :: spacing.uniform_step,
    ] = True
    return mask


def random_mask(
    spacing: MaskSpacing, count: int | None = None, seed: int | None = 0
) -> NDArray[np.bool_]:
    """Pixels opened in a random order while they keep the rule, at most ``count``.

    Examples
    --------
    >>> spacing = MaskSpacing(np.full((6, 20), 3), np.full((6, 20), 3), 2, 3.0, 3.0)
    >>> mask = random_mask(spacing, count=4, seed=1)
    >>> int(mask.sum()), len(mask_conflicts(mask, spacing))
    (4, 0)
    """
    h, w = spacing.slm_shape
    builder = MaskBuilder.empty(spacing)
    order = np.random.default_rng(seed).permutation(h * w)
    builder.fill(order, count)
    return builder.mask
