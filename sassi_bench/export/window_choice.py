"""The row window ``vsize`` of one capture, chosen by the SASSI authors' own extraction.

``get_cassi_cube`` in their ``cassi.py`` sums ``vsize`` camera rows around every pixel
(``signal.convolve2d(img, np.ones((vsize, 1)), 'same')``) and samples that sum at each
open SLM pixel's camera position per band. One integer serves all bands. A window
narrower than the blur loses the light of the wide-blur bands (at 3 rows a third of the
red end's on the ``sim`` bench), a wider one adds the noise of their offset estimate and,
on dense masks, the light of the neighbouring rows' streaks: the best window depends on
the capture's mask and exposure as much as on the blur, so it is chosen per capture.

:func:`choose_vsize` runs their extraction (:func:`~sassi_bench.export.sassi_code.
upstream_extraction`, their source unmodified) on the capture's own raw frame at every
odd window up to the widest blur's reach, and keeps the window whose spectra at the open
pixels agree best, after one gain for all pixels and bands, with this package's
extraction of the same frame (:func:`sassi_bench.snapshot.reconstruct.measure_samples`,
in camera units). That reference has its own error, far below theirs, so it ranks the
windows as the true spectra would. ``get_cassi_cube`` is ``get_cassi_img`` (the streak
image), ``get_offset`` and ``_get_cassi_cube``; the first two do not depend on
``vsize``, so they run once and ``_get_cassi_cube`` once per window, exactly as
``get_cassi_cube`` calls them (``tests/export/test_sassi_upstream.py`` checks the cube
equals ``get_cassi_cube``'s).

Examples
--------
Not run here (it needs captured frames or the authors' code)::

    choice = choose_vsize(tables, frame, mask, reference, ksizes)
    choice.vsize, choice.scores_db.round(1)
    # (9, array([22.8, 26.2, 30.2, 33.2, 34.6, 34.4, 32.0]))
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.export.sassi_code import upstream_extraction

__all__ = ["SassiTables", "VsizeChoice", "agreement_db", "candidate_windows", "choose_vsize"]

#: Widest window tried, in blur sigmas of the widest band on each side of the streak.
REACH_SIGMAS = 2.5


@dataclass(frozen=True)
class SassiTables:
    """The four calibration tables as ``cassi.py``'s ``__main__`` hands them to
    ``get_cassi_cube``: 0-based float32 (the files' values minus 1).

    Attributes
    ----------
    xl, yl
        ``(Hl, Wl, T)``: camera row and column of every SLM pixel per band (``Xl``/``Yl``).
    calibstack_row, calibstack_col
        ``(Hc, Wc, T)``: SLM row and column each camera pixel sees per band (-1: none).
    """

    xl: NDArray[np.float32]
    yl: NDArray[np.float32]
    calibstack_row: NDArray[np.float32]
    calibstack_col: NDArray[np.float32]


@dataclass(frozen=True)
class VsizeChoice:
    """What :func:`choose_vsize` tried and kept.

    Attributes
    ----------
    vsize
        The window kept.
    candidates
        The windows tried (odd, increasing).
    scores_db
        Per window, the agreement (dB, one gain) of their spectra with the reference.
    """

    vsize: int
    candidates: NDArray[np.int64]
    scores_db: NDArray[np.float64]


def candidate_windows(sigma_px: ArrayLike) -> NDArray[np.int64]:
    """Odd windows from 1 row up to :data:`REACH_SIGMAS` of the widest blur on each side.

    Examples
    --------
    >>> candidate_windows([0.4, 1.0, 3.4]).tolist()
    [1, 3, 5, 7, 9, 11, 13, 15, 17, 19]
    """
    half = int(np.ceil(REACH_SIGMAS * float(np.max(sigma_px))))
    return np.arange(1, 2 * half + 2, 2)


def agreement_db(estimate: ArrayLike, reference: ArrayLike) -> float:
    """PSNR (dB) of ``estimate`` against ``reference`` after one least-squares gain on the
    reference for all values (peak: the scaled reference's maximum).

    Examples
    --------
    >>> round(agreement_db([2.0, 4.1, 6.0], [1.0, 2.0, 3.0]), 1)
    41.9
    """
    est = np.asarray(estimate, dtype=np.float64)
    ref = np.asarray(reference, dtype=np.float64)
    power = float((ref * ref).sum())
    if not power > 0:
        raise ProcedureError(
            step_error(
                "vsize choice",
                "the reference spectra at the open pixels are all zero",
                "export a frame with light on the open pixels",
            )
        )
    scaled = float((est * ref).sum()) / power * ref
    error = float(np.mean((est - scaled) ** 2))
    peak = float(scaled.max())
    if error == 0.0:
        return float("inf")
    return float(10.0 * np.log10(max(peak, 1e-300) ** 2 / error))


def choose_vsize(
    tables: SassiTables,
    frame: ArrayLike,
    mask: ArrayLike,
    reference: ArrayLike,
    ksizes: ArrayLike,
    candidates: ArrayLike | None = None,
    sigma_px: ArrayLike | None = None,
) -> VsizeChoice:
    """The window at which the authors' extraction of ``frame`` best matches ``reference``.

    Parameters
    ----------
    tables
        The calibration tables, 0-based (:class:`SassiTables`).
    frame
        The raw spectral frame ``(Hc, Wc)``.
    mask
        The SLM pattern ``(Hl, Wl)``, 0/1 (as ``lcos_mask / 255``).
    reference
        ``(N, T)`` spectra of the open pixels (row-major, as ``np.nonzero(mask)``) at the
        tables' bands, from another extraction of the same frame.
    ksizes
        The blur list passed to ``get_cassi_cube`` (``ksizes`` of ``calibstack.mat``).
    candidates
        Windows to try (odd); default :func:`candidate_windows` of ``sigma_px``.
    sigma_px
        The blur sigma per band (camera px), for the default candidates.

    Returns
    -------
    VsizeChoice

    Examples
    --------
    Not run here (it needs captured frames or the authors' code)::

        choose_vsize(tables, frame, mask, spectra, ksizes, sigma_px=sigma).vsize
        # 9
    """
    code = upstream_extraction()
    if candidates is None:
        if sigma_px is None:
            raise ProcedureError(
                step_error("vsize choice", "no candidate windows", "pass candidates or sigma_px")
            )
        candidates = candidate_windows(sigma_px)
    windows = np.asarray(candidates, dtype=np.int64)
    if windows.size == 0 or np.any(windows < 1) or np.any(windows % 2 == 0):
        raise ProcedureError(
            step_error("vsize choice", f"windows {windows.tolist()}", "pass odd windows >= 1")
        )
    image = np.asarray(frame, dtype=np.float32)
    pattern = np.asarray(mask, dtype=np.float32)
    hl, wl, bands = tables.xl.shape
    # get_cassi_cube, with the steps that do not depend on vsize taken out of the loop:
    streak_img = code.get_cassi_img(
        [hl, wl, bands], pattern, tables.calibstack_row, tables.calibstack_col,
        np.asarray(ksizes, dtype=np.float64),
    )  # fmt: skip
    offset_img = code.get_offset(image, streak_img)
    cleaned = image - offset_img
    cleaned[cleaned < 0] = 0
    open_pixels = np.nonzero(pattern > 0)
    ref = np.asarray(reference, dtype=np.float64)
    scores = np.empty(windows.size)
    for i, window in enumerate(windows):
        cube = code._get_cassi_cube(cleaned, pattern, tables.yl, tables.xl, int(window), None)
        scores[i] = agreement_db(cube[open_pixels], ref)
    best = int(np.nanargmax(np.where(np.isfinite(scores), scores, -np.inf)))
    return VsizeChoice(int(windows[best]), windows, scores)
