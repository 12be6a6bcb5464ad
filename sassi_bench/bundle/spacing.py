"""Mask spacing: how far apart open SLM pixels must be so that their streaks never overlap.

A snapshot opens many SLM pixels at once; each one's light is a streak on the camera from
400 to 700 nm, blurred. Two open pixels may share camera pixels only if the extraction can
separate them, so a mask must keep every pair of open pixels apart. This module derives
that separation from a bundle, per field position (the streak length, the relay's scale
and the blur all change over the field), for consumers that design masks.

The rule (what :class:`MaskSpacing` promises and consumers rely on)
--------------------------------------------------------------------
A pixel open at ``(u, v)`` forbids every other open pixel ``(u', v')`` with

    ``v - pitch + 1 <= v' <= v + pitch - 1``  and
    ``u - left[v, u] <= u' <= u + right[v, u]``.

A mask is valid when no open pixel lies in the forbidden window of another (the relation
is checked both ways: ``A`` may not lie in ``B``'s window nor ``B`` in ``A``'s).

Where the numbers come from:

* **Footprint.** The light of pixel ``(u, v)`` covers camera columns from its streak's
  400 nm end to its 700 nm end (the bundle's first and last bin edges), widened at each end
  by ``margin_px`` (light just outside the band, which the extraction's guard bins absorb)
  and by ``blur_sigmas`` times the blur sigma at that end; and camera rows from the
  streak's highest to its lowest bin centre widened by ``row_sigmas`` (default
  ``blur_sigmas``) times the largest blur sigma. These are the rectangles the offset
  removal treats as lit (:func:`sassi_bench.spectra.offset.footprint_rectangles`, same
  defaults).
* **right / left.** ``right[v, u]`` is the largest column distance ``d`` such that some pixel
  ``(u + d, v')`` with ``|v' - v| < pitch`` has a camera footprint whose column range
  overlaps that of ``(u, v)`` (exact for every row of the band: the maximum over them);
  ``left`` likewise to the left. So a mask that keeps the rule has column ranges that do
  not overlap between any two open pixels less than ``pitch`` rows apart.
* **pitch.** The smallest row distance at which the row ranges of two footprints cannot
  overlap anywhere on the field, including the rows a footprint drifts by across its own
  forbidden window (relay rotation). Pixels ``pitch`` or more rows apart may therefore sit
  at any columns.

With the default ``blur_sigmas = 3`` no two footprints share a camera pixel, so each open
pixel's cells hold less than about 1e-3 of any other pixel's light (the extraction sums
each bin over +-3 sigma rows; a neighbour 6 sigma away puts ``1 - Phi(3)`` there). The
SASSI paper uses a 5 px vertical pitch with overlapping streaks unmixed by the vertical
blur model; ``row_pitch`` gives that denser rule in the same form: the pitch is the given
number of rows and ``left``/``right`` keep pixels fewer rows apart than it in disjoint
camera columns. Pixels ``row_pitch`` or more rows apart may then share camera pixels; the
extraction unmixes them (pixels of one SLM column by a banded solve per column, of
neighbouring columns jointly: :mod:`sassi_bench.spectra.crosstalk`). A smaller
``blur_sigmas`` gives denser masks at the price of crosstalk at the blurry ends of the
streaks.

Examples
--------
>>> spacing = mask_spacing(bundle.models)
>>> int(spacing.right[200, 320]), spacing.pitch
(40, 20)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numba
import numpy as np
from numpy.polynomial import legendre
from numpy.typing import NDArray

from sassi_bench._shared.arrays import check_ndim, check_shape_equality
from sassi_bench.bundle.errors import BundleError
from sassi_bench.bundle.model_types import DispersionModel
from sassi_bench.bundle.models import CalibrationModels
from sassi_bench.errors import step_error
from sassi_bench.maths.legendre import field_coordinates, horner, legendre2d_terms

__all__ = ["MaskSpacing", "mask_spacing"]

#: Default blur widths added at each end of a footprint (both directions).
BLUR_SIGMAS = 3.0
#: Default camera columns added at each end of a streak for light just outside 400-700 nm.
MARGIN_PX = 3.0


@dataclass(frozen=True, eq=False)
class MaskSpacing:
    """The minimum separation of open SLM pixels, per field position.

    See the module docstring for the exact rule. Arrays are read-only.

    Attributes
    ----------
    left, right
        ``(H, W)`` int32: columns forbidden to the left and right of an open pixel at
        ``[v, u]`` (its forbidden window is ``u - left .. u + right``, inclusive).
    pitch
        Rows: a pixel forbids rows ``v - pitch + 1 .. v + pitch - 1`` (>= 1).
    blur_sigmas, margin_px, row_sigmas
        The parameters the footprints were widened with (``row_sigmas`` above and below).

    Examples
    --------
    >>> s = MaskSpacing(np.full((4, 6), 2, np.int32), np.full((4, 6), 2, np.int32), 2, 3.0, 3.0)
    >>> s.window(3, 1)  # rows v0..v1, columns u0..u1 (inclusive, clipped to the SLM)
    (0, 2, 1, 5)
    >>> s.uniform_step
    3
    """

    left: NDArray[np.int32]
    right: NDArray[np.int32]
    pitch: int
    blur_sigmas: float
    margin_px: float
    row_sigmas: float | None = None

    def __post_init__(self) -> None:
        for name in ("left", "right"):
            array = np.array(getattr(self, name), dtype=np.int32, copy=True)
            array.flags.writeable = False
            object.__setattr__(self, name, array)
        step, fix = "mask spacing", "pass left and right as (H, W) arrays of one shape"
        check_ndim(self.left, 2, step=step, name="left", fix=fix, error=ValueError)
        check_shape_equality(
            self.left, self.right, step=step, names=("left", "right"), fix=fix, error=ValueError
        )
        if int(self.pitch) < 1:
            raise ValueError(f"pitch must be >= 1, got {self.pitch}")
        object.__setattr__(self, "pitch", int(self.pitch))
        if self.row_sigmas is None:
            object.__setattr__(self, "row_sigmas", float(self.blur_sigmas))

    @property
    def slm_shape(self) -> tuple[int, int]:
        """SLM ``(H, W)``."""
        return (int(self.left.shape[0]), int(self.left.shape[1]))

    @property
    def uniform_step(self) -> int:
        """Column step of a regular lattice that keeps the rule everywhere on the field:
        one more than the largest ``left`` or ``right``."""
        return int(max(self.left.max(), self.right.max())) + 1

    def window(self, u: int, v: int) -> tuple[int, int, int, int]:
        """Forbidden window of a pixel open at ``(u, v)``: ``(v0, v1, u0, u1)``, inclusive,
        clipped to the SLM."""
        h, w = self.slm_shape
        return (
            max(0, v - self.pitch + 1),
            min(h - 1, v + self.pitch - 1),
            max(0, u - int(self.left[v, u])),
            min(w - 1, u + int(self.right[v, u])),
        )


def _field_polynomials(model: DispersionModel) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """``cx, cy`` of every SLM pixel, ``(K, H, W)``: the field basis is a product of Legendre
    polynomials in û and v̂, so each power's field is one small matrix product."""
    h, w = model.slm_shape
    degree = model.field_degree
    u_hat, v_hat = field_coordinates(np.arange(w), np.arange(h), (h, w))
    pu = legendre.legvander(u_hat, degree)  # (W, D + 1)
    pv = legendre.legvander(v_hat, degree)  # (H, D + 1)
    terms = legendre2d_terms(degree)
    out = []
    for coeffs in (model.x_coeffs, model.row_coeffs):
        fields = np.empty((coeffs.shape[0], h, w))
        for k, row in enumerate(coeffs):
            grid = np.zeros((degree + 1, degree + 1))  # [j, i]: P_j(v̂) P_i(û)
            for t, (i, j) in enumerate(terms):
                grid[j, i] = row[t]
            fields[k] = pv @ grid @ pu.T
        out.append(fields)
    return out[0], out[1]


def _row_range(cy, s_ends) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Lowest and highest camera row of every pixel's streak between the band's ends: the
    row is a polynomial in its spectral coordinate; for a quadratic its extremes are at the
    ends or at the vertex, otherwise it is sampled finely."""
    s0, s1 = float(min(s_ends)), float(max(s_ends))
    if cy.shape[0] <= 3:
        points = [horner(s0, cy), horner(s1, cy)]
        if cy.shape[0] == 3:
            with np.errstate(divide="ignore", invalid="ignore"):
                vertex = np.clip(-cy[1] / (2.0 * cy[2]), s0, s1)
            vertex = np.where(np.isfinite(vertex), vertex, s0)
            points.append(cy[0] + vertex * (cy[1] + vertex * cy[2]))
    else:
        points = [horner(float(s), cy) for s in np.linspace(s0, s1, 65)]
    return np.minimum.reduce(points), np.maximum.reduce(points)


@numba.njit(cache=False, nogil=True)
def _reach(lo, hi, pitch, right):  # pragma: no cover - compiled
    """``right[v, u]``: the largest ``d >= 0`` such that ``lo[v', u + d] <= hi[v, u]`` for a
    row ``|v' - v| < pitch`` (``lo`` and ``hi`` increase along each row): a two-pointer
    walk per pair of rows."""
    h, w = lo.shape
    for v in range(h):
        for u in range(w):
            right[v, u] = 0
        for vv in range(max(0, v - pitch + 1), min(h, v + pitch)):
            j = 0
            for u in range(w):
                if j < u:
                    j = u
                while j + 1 < w and lo[vv, j + 1] <= hi[v, u]:
                    j += 1
                if j - u > right[v, u]:
                    right[v, u] = j - u


def _reaches(lo, hi, pitch: int) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """``left, right`` from footprints whose camera columns increase along the rows."""
    right = np.empty(lo.shape, dtype=np.int32)
    _reach(np.ascontiguousarray(lo), np.ascontiguousarray(hi), pitch, right)
    # The left reach is the right reach of the mirrored field (u -> W - 1 - u, x -> -x).
    mirrored = np.empty(lo.shape, dtype=np.int32)
    _reach(np.ascontiguousarray(-hi[:, ::-1]), np.ascontiguousarray(-lo[:, ::-1]), pitch, mirrored)
    return np.ascontiguousarray(mirrored[:, ::-1]), right


class _HasModels(Protocol):
    """What carries calibration models: a :class:`~sassi_bench.bundle.CalibrationBundle`."""

    @property
    def models(self) -> CalibrationModels: ...


def mask_spacing(
    calibration: CalibrationModels | _HasModels,
    *,
    blur_sigmas: float = BLUR_SIGMAS,
    margin_px: float = MARGIN_PX,
    row_sigmas: float | None = None,
    row_pitch: int | None = None,
) -> MaskSpacing:
    """The separation open SLM pixels need so that their streaks never overlap.

    Parameters
    ----------
    calibration
        A bundle, or its ``models`` (dispersion, bins and blur: all the rule needs).
    blur_sigmas
        Blur sigmas added at each end of a streak's footprint, horizontally (with the
        sigma at that end) and vertically (with the largest sigma). 3 keeps every pair of
        footprints apart (crosstalk below about 1e-3).
    margin_px
        Camera columns added at each end for light just outside 400-700 nm.
    row_sigmas
        Blur sigmas added above and below instead (default: ``blur_sigmas``). The pitch
        follows the widest blur (at the ends of the band) for every pair; a smaller value
        packs rows closer at the price of crosstalk where two pixels' blurry ends meet.
    row_pitch
        The pitch in SLM rows instead of the one that keeps footprints apart (the SASSI
        paper's 5): pixels at least this many rows apart may overlap on the camera, and
        the extraction unmixes them (:mod:`sassi_bench.spectra.crosstalk`). ``left`` and
        ``right`` are computed for this pitch.

    Returns
    -------
    MaskSpacing
        The forbidden window of every SLM pixel (see the module docstring for the rule).

    Raises
    ------
    BundleError
        If a parameter is negative, or the streaks' camera columns do not move monotonically
        along the SLM rows (no consistent left and right).

    Examples
    --------
    >>> spacing = mask_spacing(bundle.models)
    >>> spacing.window(320, 200)
    (181, 219, 280, 360)
    """
    step = "mask spacing"
    models = getattr(calibration, "models", calibration)
    if not (np.isfinite(blur_sigmas) and blur_sigmas >= 0):
        raise BundleError(step_error(step, f"blur_sigmas is {blur_sigmas}", "pass a number >= 0"))
    if not (np.isfinite(margin_px) and margin_px >= 0):
        raise BundleError(step_error(step, f"margin_px is {margin_px}", "pass a number >= 0"))
    model = models.dispersion
    cx, cy = _field_polynomials(model)
    edges = np.asarray(models.bins.edges_nm, dtype=np.float64)
    centres = np.asarray(models.bins.centres_nm, dtype=np.float64)
    sigma_ends = np.asarray(models.blur.sigma(edges[[0, -1]]), dtype=np.float64)
    sigma_max = float(np.max(models.blur.sigma(np.linspace(edges[0], edges[-1], 257))))
    reach = blur_sigmas * sigma_ends + margin_px
    ends = [horner(float(s), cx) for s in model.spectral_x(edges[[0, -1]])]
    lo = np.minimum(ends[0] - reach[0], ends[1] - reach[1])
    hi = np.maximum(ends[0] + reach[0], ends[1] + reach[1])
    del ends
    increasing = bool(np.all(np.diff(lo, axis=1) > 0) and np.all(np.diff(hi, axis=1) > 0))
    decreasing = bool(np.all(np.diff(lo, axis=1) < 0) and np.all(np.diff(hi, axis=1) < 0))
    if not (increasing or decreasing):
        raise BundleError(
            step_error(
                step,
                "the streaks' camera columns do not move monotonically along the SLM rows",
                "check the bundle's dispersion fit (sassi-bench bundle verify) and the relay",
            )
        )
    # Vertical extent of a footprint: the rows its bin centres span, plus the blur.
    y_low, y_high = _row_range(cy, model.row_coordinate(centres[[0, -1]]))
    rows_k = blur_sigmas if row_sigmas is None else row_sigmas
    if not (np.isfinite(rows_k) and rows_k >= 0):
        raise BundleError(step_error(step, f"row_sigmas is {row_sigmas}", "pass a number >= 0"))
    top = y_low - rows_k * sigma_max
    bottom = y_high + rows_k * sigma_max
    y_mid = 0.5 * (top + bottom)
    rows_per_v = np.abs(np.diff(y_mid, axis=0))  # camera rows per SLM row
    tilt = np.abs(np.diff(y_mid, axis=1)).max()  # camera rows per SLM column
    if rows_per_v.min() <= 0:
        raise BundleError(
            step_error(
                step,
                "the streaks of neighbouring SLM rows land on the same camera row",
                "check the bundle's dispersion fit (sassi-bench bundle verify)",
            )
        )
    if row_pitch is not None:
        if isinstance(row_pitch, bool) or int(row_pitch) != row_pitch or row_pitch < 1:
            raise BundleError(
                step_error(step, f"row_pitch is {row_pitch!r}", "pass a whole number of rows >= 1")
            )
        pitch = int(row_pitch)
        left, right = _window_reaches(lo, hi, pitch, increasing)
        return MaskSpacing(left, right, pitch, float(blur_sigmas), float(margin_px), float(rows_k))
    # A first pitch from the footprint's own height, then widened by the drift across the
    # forbidden window (which needs the windows, which need the pitch): iterate to a fixpoint.
    height = float((bottom - top).max())
    pitch = int(np.floor(height / rows_per_v.min())) + 1
    for _ in range(8):
        left, right = _window_reaches(lo, hi, pitch, increasing)
        drift = tilt * float((left + right).max())
        needed = int(np.floor((height + drift) / rows_per_v.min())) + 1
        if needed <= pitch:
            break
        pitch = needed
    return MaskSpacing(left, right, pitch, float(blur_sigmas), float(margin_px), float(rows_k))


def _window_reaches(lo, hi, pitch: int, increasing: bool):
    """``left, right`` in SLM columns, whichever way the camera columns run along u."""
    if increasing:
        return _reaches(lo, hi, pitch)
    # Mirror u so the camera columns increase; what lies right on the mirrored SLM lies left.
    left_m, right_m = _reaches(-hi[:, ::-1], -lo[:, ::-1], pitch)
    return np.ascontiguousarray(right_m[:, ::-1]), np.ascontiguousarray(left_m[:, ::-1])
