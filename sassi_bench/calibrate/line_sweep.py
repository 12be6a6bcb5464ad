"""Decoding the paper's line sweep: one SLM column (or row) at a time, several at once.

Each frame shows open SLM columns ``u = offset + k * spacing`` (axis "x") or rows
(axis "y"). In every camera row (column), the image of a line is a short run of bright
pixels whose intensity-weighted centre is found by a thresholded centre of mass. The
centres of all frames are then fitted with a smooth polynomial ``u(x, y)`` (``v(x, y)``)
over the camera, rejecting outliers, which gives a sub-pixel SLM coordinate for every
illuminated camera pixel: the same correspondences the structured-light sweep gives.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from sassi_bench.calibrate.field import FieldFit, fit_field
from sassi_bench.errors import ProcedureError, step_error

__all__ = ["LineCentres", "fit_line_axis", "line_centres"]


@dataclass(frozen=True)
class LineCentres:
    """Centres of line images: camera (x, y) and the SLM coordinate of the line.

    Attributes
    ----------
    x, y
        Camera column and row of every centre (N,): sub-pixel across the line, the
        pixel row (axis "x") or column (axis "y") along it.
    slm
        The SLM column (axis "x") or row (axis "y") of the line each centre belongs
        to (N,).
    skipped_frames
        Frames whose line images could not be matched one-to-one with the open lines.
    """

    x: NDArray[np.float64]
    y: NDArray[np.float64]
    slm: NDArray[np.float64]
    skipped_frames: int


def _runs(mask: NDArray[np.bool_]) -> tuple[NDArray, NDArray, NDArray]:
    """Start/stop (exclusive) of True runs along the last axis, with their row index."""
    padded = np.pad(mask, ((0, 0), (1, 1)))
    edges = np.diff(padded.astype(np.int8), axis=1)
    row_s, start = np.nonzero(edges == 1)
    _, stop = np.nonzero(edges == -1)
    return row_s, start, stop


def line_centres(
    signals: Sequence[NDArray],
    offsets: Sequence[int],
    spacing: int,
    axis: str,
    slm_length: int,
    threshold_fraction: float = 0.25,
) -> LineCentres:
    """Thresholded centres of mass of line images in background-free frames.

    Parameters
    ----------
    signals
        Frames minus a closed-SLM frame, one per line offset, (H, W) each.
    offsets
        First open SLM column (row) of each frame.
    spacing
        SLM pixels between the lines open together.
    axis
        ``"x"``: lines are SLM columns, centres are found along camera rows;
        ``"y"``: lines are SLM rows, centres along camera columns.
    slm_length
        SLM width (axis "x") or height (axis "y").
    threshold_fraction
        Pixels above this fraction of the frame's bright level belong to a line.

    Returns
    -------
    LineCentres
        Frames whose line images cannot be matched one-to-one with the open lines are
        skipped and counted.
    """
    xs, ys, coords, skipped = [], [], [], 0
    for signal, offset in zip(signals, offsets, strict=True):
        image = np.asarray(signal, dtype=np.float64)
        if axis == "y":
            image = image.T
        level = threshold_fraction * np.percentile(image, 99.9)
        row, start, stop = _runs(image > level)
        if row.size == 0:
            skipped += 1
            continue
        # Weights above the threshold: a plain centre of mass over a whole-pixel run is
        # pulled towards the run's middle by up to ~0.2 px for off-centre lines.
        excess = np.clip(image - level, 0.0, None)
        cum = np.cumsum(np.pad(excess, ((0, 0), (1, 0))), axis=1)
        pos = np.arange(image.shape[1] + 1, dtype=np.float64)
        cum_x = np.cumsum(np.pad(excess * pos[None, :-1], ((0, 0), (1, 0))), axis=1)
        weight = cum[row, stop] - cum[row, start]
        centre = (cum_x[row, stop] - cum_x[row, start]) / weight
        lines = np.arange(offset, slm_length, spacing)
        # Line images are nearly parallel to the camera axis: group centres by their
        # position across the lines, splitting at gaps wider than 0.4 line spacings.
        order = np.argsort(centre)
        gaps = np.diff(centre[order]) > 0.4 * spacing
        label = np.empty(centre.size, dtype=np.intp)
        label[order] = np.concatenate([[0], np.cumsum(gaps)])
        if label.max() + 1 != lines.size:
            skipped += 1
            continue
        coords.append(lines[label].astype(np.float64))
        along = centre if axis == "x" else row.astype(np.float64)
        across = row.astype(np.float64) if axis == "x" else centre
        xs.append(along)
        ys.append(across)
    if not coords:
        raise ProcedureError(
            step_error(
                "line sweep",
                f"no frame of axis {axis!r} showed its lines clearly",
                "check the exposure and that the laser illuminates the SLM",
            )
        )
    return LineCentres(np.concatenate(xs), np.concatenate(ys), np.concatenate(coords), skipped)


def fit_line_axis(centres: LineCentres, camera_shape: tuple[int, int], degree: int = 5) -> FieldFit:
    """Fit the SLM coordinate of the lines as a smooth function of camera position.

    Parameters
    ----------
    centres
        From :func:`line_centres`.
    camera_shape
        The camera's (height, width): the polynomial's domain.
    degree
        Total degree of the field polynomial.

    Returns
    -------
    FieldFit
        Called with camera coordinates: ``fit(x, y)`` is the SLM coordinate.

    Examples
    --------
    >>> y, x = np.mgrid[0:40:4, 0:60:3].astype(float)
    >>> centres = LineCentres(x.ravel(), y.ravel(), 2.0 * x.ravel() + 0.1 * y.ravel(), 0)
    >>> fit = fit_line_axis(centres, (40, 60), degree=1)
    >>> round(float(fit(np.array([10.0]), np.array([20.0]))[0]), 6)
    22.0
    """
    return fit_field(centres.x, centres.y, centres.slm, camera_shape, degree)
