"""Figures of the guide registration: the feature matches and a checkerboard blend."""

from __future__ import annotations

from typing import Any

import cv2
import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["checkerboard", "checkerboard_figure", "guide_figures", "matches_figure"]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


def _display(image: ArrayLike, valid: ArrayLike | None = None) -> NDArray[np.float64]:
    """RGB in [0, 1] for display: each channel stretched between robust percentiles."""
    data = np.asarray(image, dtype=np.float64)
    if data.ndim == 2:
        data = np.repeat(data[..., None], 3, axis=-1)
    keep = np.ones(data.shape[:2], bool) if valid is None else np.asarray(valid, bool)
    if not keep.any():
        return np.zeros(data.shape)
    lo = np.percentile(data[keep], 0.5, axis=0)
    hi = np.percentile(data[keep], 99.5, axis=0)
    out = np.clip((data - lo) / np.maximum(hi - lo, 1e-12), 0.0, 1.0)
    out[~keep] = 0.0
    return out


def checkerboard(a: ArrayLike, b: ArrayLike, tile_px: int = 40) -> NDArray[np.float64]:
    """Tiles of ``a`` and ``b`` alternating like a checkerboard (same shapes).

    Parameters
    ----------
    a, b
        (H, W) or (H, W, C) images of one shape; ``a`` fills the top-left tile.
    tile_px
        Side of a square tile in pixels.

    Returns
    -------
    ndarray
        float64, the shape of ``a``.

    Examples
    --------
    >>> checkerboard(np.zeros((2, 4)), np.ones((2, 4)), tile_px=2).tolist()
    [[0.0, 0.0, 1.0, 1.0], [0.0, 0.0, 1.0, 1.0]]
    """
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    rows, cols = np.indices(a.shape[:2])
    pick = ((rows // tile_px + cols // tile_px) % 2).astype(bool)
    if a.ndim == 3:
        pick = pick[..., None]
    return np.where(pick, b, a)


def matches_figure(registration, guide_image: ArrayLike, slm_image: ArrayLike, *, limit: int = 300):
    """The guide image and the SLM rendering side by side with the matched features:
    inliers green, rejected matches red.

    Parameters
    ----------
    registration
        A :class:`~sassi_bench.calibrate.guide_registration.Registration`: its matched
        points (guide, SLM), inlier flags and quality.
    guide_image
        The guide camera's image the features were found in.
    slm_image
        The rendering of the scene on the SLM grid.
    limit
        Most matches drawn of each kind (a random subset beyond).

    Returns
    -------
    matplotlib.figure.Figure
        One panel; the title gives the inlier count, the reprojection RMS and coverage.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig = matches_figure(result.registration, result.guide_image,
                             result.reference.image)
    """
    guide = _display(guide_image)
    slm = _display(slm_image)
    height = max(guide.shape[0], slm.shape[0])
    gap = 12
    canvas = np.ones((height, guide.shape[1] + gap + slm.shape[1], 3))
    canvas[: guide.shape[0], : guide.shape[1]] = guide
    offset = guide.shape[1] + gap
    canvas[: slm.shape[0], offset:] = slm
    fig = _figure(figsize=(11, 11 * height / canvas.shape[1] + 0.8), layout="constrained")
    ax = fig.subplots()
    ax.imshow(canvas, interpolation="nearest")
    from matplotlib.collections import LineCollection

    src, dst, inlier = registration.guide_points, registration.slm_points, registration.inlier
    rng = np.random.default_rng(0)
    for keep, colour, width in ((~inlier, "red", 0.5), (inlier, "lime", 0.7)):
        index = np.flatnonzero(keep)
        if index.size > limit:
            index = np.sort(rng.choice(index, limit, replace=False))
        segments = np.stack([src[index], dst[index] + [offset, 0]], axis=1)
        ax.add_collection(LineCollection(segments, colors=colour, linewidths=width, alpha=0.8))
        ax.scatter(*src[index].T, s=6, c=colour)
        ax.scatter(*(dst[index] + [offset, 0]).T, s=6, c=colour)
    q = registration.quality
    ax.set_title(
        f"guide image (left) and SLM rendering (right): {q.inliers} of {q.matches} matches "
        f"are inliers, reprojection RMS {q.rms_px:.2f} px, coverage {q.coverage:.0%}",
        fontsize=9,
    )
    ax.set_axis_off()
    return fig


def checkerboard_figure(
    homography: ArrayLike,
    guide_image: ArrayLike,
    slm_image: ArrayLike,
    slm_valid: ArrayLike | None = None,
    *,
    tile_px: int = 40,
):
    """The guide image warped onto the SLM grid, tiled with the SLM rendering: edges that
    run on unbroken across tile borders show the fit. Right: the central quarter, enlarged.

    Parameters
    ----------
    homography
        (3, 3) guide -> SLM homography.
    guide_image
        The guide camera's image.
    slm_image
        The rendering of the scene on the SLM grid, (H, W) or (H, W, C).
    slm_valid
        (H, W) pixels of the rendering to show; all by default.
    tile_px
        Side of a checkerboard tile in SLM pixels.

    Returns
    -------
    matplotlib.figure.Figure
        The whole blend and its enlarged centre.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> image = rng.random((60, 80))
    >>> fig = checkerboard_figure(np.eye(3), image, image, tile_px=10)
    >>> len(fig.axes)
    2
    """
    slm = np.asarray(slm_image)
    height, width = slm.shape[:2]
    warped = cv2.warpPerspective(
        np.ascontiguousarray(np.asarray(guide_image, dtype=np.float32)),
        np.asarray(homography, dtype=np.float64),
        (width, height),
        flags=cv2.INTER_LINEAR,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=0,
    )
    seen = (
        cv2.warpPerspective(
            np.ones(np.asarray(guide_image).shape[:2], np.float32),
            np.asarray(homography, dtype=np.float64),
            (width, height),
            flags=cv2.INTER_NEAREST,
        )
        > 0
    )
    valid = seen if slm_valid is None else seen & np.asarray(slm_valid, bool)
    blend = checkerboard(_display(warped, valid), _display(slm, valid), tile_px)
    fig = _figure(figsize=(11, 11 * height / (2 * width) + 0.9), layout="constrained")
    ax_all, ax_zoom = fig.subplots(1, 2)
    ax_all.imshow(blend, interpolation="nearest")
    r0, c0 = height // 2 - height // 8, width // 2 - width // 8
    from matplotlib.patches import Rectangle

    box = Rectangle((c0 - 0.5, r0 - 0.5), width // 4, height // 4, fill=False, ec="yellow")
    ax_all.add_patch(box)
    ax_all.set_title(f"warped guide / SLM rendering, {tile_px} px tiles", fontsize=9)
    ax_zoom.imshow(
        blend[r0 : r0 + height // 4, c0 : c0 + width // 4],
        interpolation="nearest",
        extent=(c0 - 0.5, c0 + width // 4 - 0.5, r0 + height // 4 - 0.5, r0 - 0.5),
    )
    ax_zoom.set_title("centre, enlarged", fontsize=9)
    for ax in (ax_all, ax_zoom):
        ax.set_xlabel("SLM u (px)")
        ax.set_ylabel("SLM v (px)")
    return fig


def guide_figures(result) -> dict[str, Any]:
    """Both figures of a :class:`~sassi_bench.reduce.guide.GuideRegistration`.

    Parameters
    ----------
    result
        The registration result: its ``registration``, ``homography``, ``guide_image``
        and ``reference`` (the SLM rendering and where it is valid).

    Returns
    -------
    dict
        ``"guide_matches"`` (:func:`matches_figure`) and ``"guide_checkerboard"``
        (:func:`checkerboard_figure`).

    Examples
    --------
    Not run here (it needs a procedure's result)::

        figures = guide_figures(result)
        sorted(figures)
        # ['guide_checkerboard', 'guide_matches']
    """
    ref = result.reference
    return {
        "guide_matches": matches_figure(result.registration, result.guide_image, ref.image),
        "guide_checkerboard": checkerboard_figure(
            result.homography, result.guide_image, ref.image, ref.valid
        ),
    }
