"""Every spacing a capture plan needs, derived from the rig's nominal optics at plan time.

A pinhole scan's pitch, the lamp frames' and the blur frames' pinhole pitch, the phase
sweep's period and Gray block, and the guide registration's inlier count depend on the
bench: how long a streak is on the camera, how wide a spot, how many camera rows an SLM
row spans, how large the SLM field is. :func:`plan_geometry` derives them from the rig's
description only: the described relay and prism (``RigDescription.nominal_relay()``, a
ray trace; a rig described by its optical design comes through the same seam), the
described PSF curve, the SLM and the camera. Never from how the bench is built.

A procedure file gives these values as ``null`` (or leaves them out): the derived value is
used. A number is an override; an override that would let streaks overlap is refused by
the checks of :mod:`~sassi_bench.acquire.streak_pitch` and
:func:`~sassi_bench.acquire.spectral_plans.check_lamp_pitch`. A spacing that cannot fit
the SLM at all is refused here, naming the optical change that would make it fit.

The rules (camera px unless said; ``s(l)`` the described spot sigma of one SLM pixel,
``s_max`` its widest over 400-700 nm, ``s_las`` its widest at the lasers):

- scan pitch, horizontal: the smallest pitch whose neighbouring streaks, each marked as
  the scan's reading pass marks it (400-700 nm, 4 sigmas and 6 px beyond each end), leave
  at least one SLM pixel's step of free columns everywhere on the field, rounded up to a
  multiple of the guide scan's stride; vertical: ``ceil(1.5 s_max / (rows per SLM row))``
  (stacked pinholes at least 1.5 of the widest row sigmas apart, what the row unmixing
  needs; ``sim``'s 5);
- lamp pitch, horizontal: as the scan's, over the lamps' lines on the spectral grid, 4
  sigmas and 1 px beyond the first and last line; vertical: the rows the lamp reduction
  cuts around a streak (3 ``s_max`` and half the streak's row drift, at most 10) and two
  rows each side, over the rows one SLM row spans;
- blur pitch: isolated laser spots, each read in a window of 4.5 sigmas each side
  (:func:`~sassi_bench.calibrate.blur.measure_spot_widths`) with 2 px between windows;
- phase period: the sinusoid keeps half its contrast through the widest laser spot
  (``exp(-2 pi^2 s_las^2 / P^2) >= 0.5``), in whole phase steps, at least 16 SLM px; the
  Gray block is half
  the period (the Gray code must resolve one period);
- guide inliers: 30 on a 640 x 400 SLM field, in proportion to the field's area, at
  least 12 (a smaller field shows proportionally less texture; a homography has 8
  unknowns);
- field degree of the fits (``fit.field_degree``): the lowest Legendre degree from 5 whose
  series reproduces the described optics' streak columns and rows over the SLM field
  within a hundredth of a pixel at every wavelength of the band, at most 11
  (:func:`field_degree`; a wide, off-axis, rotated and distorted field needs more terms
  than a small centred one, and a degree too low leaves the map a pixel off at the
  corners while every laser map fits within its tolerance);
- dispersion order of the fits (``fit.dispersion_order``): 2 (the column quadratic in the
  glass index, the row in wavelength), or 3 where the column misses the described optics'
  streaks by more than the tenth of a pixel the bundle places them to somewhere on the
  field and the rig has the lines to fit one more power: wavelength lamps, or at least
  six laser lines (:func:`dispersion_order`; a wide field imaged far off the camera's
  axis bends the streaks' columns beyond a quadratic at its edges);
- guide scan stride: every 4th horizontal pinhole offset on a 640 px wide SLM, in
  proportion to the width below it, at least 1 (the target filling a smaller field puts its
  texture on fewer SLM px, and the coarse lattice's resampling then moves the features the
  homography is fitted to: measured on a 320 x 200 SLM in
  ``docs/notes/2026-11-29-design-rig-scan-and-guide.md``).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from sassi_bench.acquire.spectral_plans import LAMP_MARGIN_PX, LAMP_REACH_SIGMAS
from sassi_bench.acquire.streak_pitch import (
    BAND_NM,
    FOOTPRINT_MARGIN_PX,
    FOOTPRINT_SIGMAS,
    described_spot_sigma,
    pitch_room,
)
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.maths.legendre import field_coordinates, legendre2d_design
from sassi_bench.optics.glass import get_glass
from sassi_bench.rig.config import RigDescription

__all__ = [
    "GUIDE_STRIDE",
    "PlanGeometry",
    "dispersion_order",
    "field_degree",
    "guide_stride",
    "plan_geometry",
    "planned_guide",
    "planned_health_check",
    "planned_macbeth",
    "planned_spectral",
    "scan_pitch",
]

#: The guide scan's default stride along the rows: derived scan pitches are multiples of it.
GUIDE_STRIDE = 4
#: Stacked pinholes of a scan are at least this many widest row sigmas apart.
ROW_SEPARATION_SIGMAS = 1.5
#: ... and at least this many of the band's median widest sigma: a spot wide over most of
#: the band (a singlet focused in the blue) mixes stacked rows in most bins, where the
#: unmixing carries its blur error and noise into every spectrum, not into a few bins at
#: the band's ends (measured on ``sim-singlet``'s chart:
#: ``docs/notes/2026-11-30-design-rig-blue-blur-and-scan-pitch.md``).
ROW_SEPARATION_MEDIAN_SIGMAS = 2.25
#: The lamp reduction cuts at most this many rows each side of a streak.
LAMP_MAX_HALF_ROWS = 10
#: Half-width of a blur spot's window, in spot sigmas.
SPOT_WINDOW_SIGMAS = 4.5
#: Sinusoid contrast kept through the widest laser spot.
PHASE_CONTRAST = 0.5
#: The shortest phase period derived (SLM px).
MIN_PHASE_PERIOD = 16
#: Guide inliers asked of a 640 x 400 SLM field, and the fewest asked of any field.
GUIDE_INLIERS = (30, 640 * 400, 12)
#: The guide scan's derived horizontal stride: ``GUIDE_STRIDE`` from this SLM width up.
GUIDE_STRIDE_WIDTH = 640
#: The fits' field degree: the lowest and highest derived, and the largest misfit (camera
#: px) of the described optics it leaves, a tenth of the tenth of a pixel the bundle
#: places streaks to.
FIELD_DEGREES = (5, 11)
FIELD_MISFIT_PX = 0.01
#: The fits' dispersion order: the paper's quadratic and the one power more derived where
#: the described optics need it; the largest misfit (camera px) of the quadratic form, the
#: tenth of a pixel the bundle places streaks to; the laser lines a rig without lamps
#: needs for the higher order (a leave-one-out refit still has a line to spare).
DISPERSION_ORDERS = (2, 3)
ORDER_MISFIT_PX = 0.1
ORDER_LASER_LINES = 6
#: Field points (columns, rows) and wavelengths the field degree is judged on.
FIELD_GRID = (33, 21)
FIELD_WAVELENGTHS = 7


@dataclass(frozen=True)
class PlanGeometry:
    """The spacings derived from a rig's nominal optics, and what they were derived from.

    Attributes
    ----------
    scan_pitch
        (horizontal, vertical) pinhole pitch of every pinhole scan, SLM px.
    lamp_pitch
        The lamp frames' pinhole pitch (None on a rig without wavelength lamps).
    blur_pitch
        The blur frames' pinhole pitch.
    phase_period, gray_block
        The structured sweep's sinusoid period and Gray block, SLM px.
    min_inliers
        Guide matches that must agree on one homography.
    streak_px
        Camera columns a scan's 400-700 nm streak footprint spans at the tightest field
        point (band, blur and margins).
    spot_sigma_px
        The described spot's narrowest and widest sigma over 400-700 nm.
    laser_spot_sigma_px
        The widest described spot at the rig's lasers.
    rows_per_slm_px
        Camera rows one SLM row spans (the fewest over the field).
    """

    scan_pitch: tuple[int, int]
    lamp_pitch: tuple[int, int] | None
    blur_pitch: tuple[int, int]
    phase_period: int
    gray_block: int
    min_inliers: int
    streak_px: float
    spot_sigma_px: tuple[float, float]
    laser_spot_sigma_px: float
    rows_per_slm_px: float

    def to_json(self) -> dict[str, Any]:
        """The geometry as JSON-compatible values (recorded with the plans)."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}


def _field_points(desc: RigDescription) -> tuple[np.ndarray, np.ndarray]:
    h, w = desc.slm.height, desc.slm.width
    v, u = np.meshgrid(np.linspace(0.0, h - 1, 5), np.linspace(0.0, w - 2, 9))
    return u.ravel()[:, None], v.ravel()[:, None]


def _rows_per_slm_px(desc: RigDescription) -> float:
    relay = desc.nominal_relay()
    u, v = _field_points(desc)
    mid = np.array([[sum(BAND_NM) / 2.0]])
    _, y0 = relay.forward(u, v, mid)
    _, y1 = relay.forward(u, v + 1.0, mid)
    return float(np.abs(y1 - y0).min())


def _row_drift_px(desc: RigDescription, band: tuple[float, float]) -> float:
    """Rows a streak drifts over a band (the relay's rotation and the prism's smile)."""
    u, v = _field_points(desc)
    _, y = desc.nominal_relay().forward(u, v, np.asarray(band, dtype=np.float64)[None, :])
    return float(np.abs(y[:, 1] - y[:, 0]).max())


def _lamp_band(desc: RigDescription) -> tuple[float, float] | None:
    grid = desc.spectral_grid
    lines = [
        float(x)
        for table in desc.lamp_lines().values()
        for x in table.wavelengths_nm
        if grid.start_nm <= x <= grid.stop_nm
    ]
    return (min(lines), max(lines)) if lines else None


def _refuse_too_long(desc: RigDescription, what: str, needed: int, footprint: float) -> None:
    w = desc.slm.width
    if needed < w:
        return
    raise ProcedureError(
        step_error(
            what,
            f"one streak with its blur spans {footprint:.0f} camera px, more than the "
            f"{w} px wide SLM's image leaves for two pinholes of a row (a pitch of {needed} "
            "SLM px would be needed)",
            "shorten the streak on the camera: a prism that disperses less (smaller "
            "prism.spread_px, e.g. N-BK7 instead of SF10), a lower relay scale, or an SLM "
            "with more columns",
        )
    )


def plan_geometry(desc: RigDescription, guide_stride: int = GUIDE_STRIDE) -> PlanGeometry:
    """Every spacing the capture plans need, from the rig's nominal description.

    Parameters
    ----------
    desc
        The rig's description (its relay and prism as described, PSF curve, SLM, lamps
        and lasers).
    guide_stride
        The guide scan's stride along the rows: the scan pitch is a multiple of it.

    Returns
    -------
    PlanGeometry

    Raises
    ------
    ProcedureError
        When a streak is too long for two pinholes of an SLM row, naming the optical
        changes that shorten it.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> geo = plan_geometry(load_rig_description("sim"))
    >>> geo.scan_pitch, geo.lamp_pitch, geo.phase_period, geo.gray_block, geo.min_inliers
    ((100, 5), (87, 24), 16, 8, 30)
    """
    lam = np.linspace(BAND_NM[0], BAND_NM[1], 31)
    spot = described_spot_sigma(desc, lam)
    s_max = float(spot.max())
    s_las = float(described_spot_sigma(desc, np.asarray(desc.lasers_nm, dtype=np.float64)).max())
    rows = _rows_per_slm_px(desc)
    scale = float(desc.relay.scale)

    room = pitch_room(desc, 100, BAND_NM, FOOTPRINT_SIGMAS, FOOTPRINT_MARGIN_PX)
    _refuse_too_long(desc, "pinhole scan", room.needed_pitch, room.footprint_px)
    stride = max(1, int(guide_stride))
    scan_u = stride * math.ceil(room.needed_pitch / stride)
    s_row = max(
        ROW_SEPARATION_SIGMAS * s_max, ROW_SEPARATION_MEDIAN_SIGMAS * float(np.median(spot))
    )
    scan_v = max(2, math.ceil(s_row / rows))

    lamp_pitch = None
    band = _lamp_band(desc)
    if band is not None:
        lamp_room = pitch_room(desc, 100, band, LAMP_REACH_SIGMAS, LAMP_MARGIN_PX)
        _refuse_too_long(desc, "lamp frames", lamp_room.needed_pitch, lamp_room.footprint_px)
        half = min(LAMP_MAX_HALF_ROWS, math.ceil(3.0 * s_max + _row_drift_px(desc, band) / 2.0))
        lamp_v = math.ceil((2 * (half + 2) + 1) / min(rows, scale))
        lamp_pitch = (lamp_room.needed_pitch, lamp_v)

    window = 2 * math.ceil(SPOT_WINDOW_SIGMAS * s_las) + 3
    blur = max(8, math.ceil(window / min(rows, scale)))

    steps = 8
    period_cam = 2.0 * math.pi * s_las / math.sqrt(2.0 * math.log(1.0 / PHASE_CONTRAST))
    # Not below 16 SLM px (the period every test rig and the family's published rigs were
    # calibrated with): shorter periods would also shrink the finest Gray block to 4 px,
    # not tried here.
    period = max(MIN_PHASE_PERIOD, steps * math.ceil(period_cam / scale / steps))

    per, area, fewest = GUIDE_INLIERS
    inliers = max(fewest, min(per, math.ceil(per * desc.slm.width * desc.slm.height / area)))
    return PlanGeometry(
        scan_pitch=(int(scan_u), int(scan_v)),
        lamp_pitch=lamp_pitch,
        blur_pitch=(int(blur), int(blur)),
        phase_period=int(period),
        gray_block=int(period // 2),
        min_inliers=int(inliers),
        streak_px=float(room.footprint_px),
        spot_sigma_px=(float(spot.min()), s_max),
        laser_spot_sigma_px=s_las,
        rows_per_slm_px=rows,
    )


def scan_pitch(
    desc: RigDescription, value: Any = None, stride: tuple[int, int] = (1, 1)
) -> tuple[int, int]:
    """A pinhole scan's pitch: ``value`` when the procedure gives one, else derived.

    Parameters
    ----------
    desc
        The rig's description.
    value
        The procedure's ``pitch_px`` (``None`` or empty: derived).
    stride
        A coarse scan's stride: a derived pitch is a multiple of it.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> desc = load_rig_description("sim")
    >>> scan_pitch(desc), scan_pitch(desc, ()), scan_pitch(desc, [96, 4])
    ((100, 5), (100, 5), (96, 4))
    """
    if value is not None and len(value):
        return int(value[0]), int(value[1])
    sx, sy = max(1, int(stride[0])), max(1, int(stride[1]))
    geo = plan_geometry(desc, GUIDE_STRIDE * sx // math.gcd(GUIDE_STRIDE, sx))
    return geo.scan_pitch[0], sy * math.ceil(geo.scan_pitch[1] / sy)


def _described_streaks(
    desc: RigDescription, wavelengths_nm: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The described optics' camera column and row (points, wavelengths) of every point of
    the ``FIELD_GRID`` over the SLM, with the points' SLM ``u`` and ``v``."""
    h, w = desc.slm.height, desc.slm.width
    v, u = np.meshgrid(
        np.linspace(0.0, h - 1, FIELD_GRID[1]), np.linspace(0.0, w - 1, FIELD_GRID[0])
    )
    u, v = u.ravel(), v.ravel()
    x, y = desc.nominal_relay().forward(u[:, None], v[:, None], wavelengths_nm[None, :])
    return u, v, x, y


def field_degree(desc: RigDescription) -> int:
    """The Legendre degree the spectral fits need over this rig's SLM field.

    The described optics (``RigDescription.nominal_relay()``) put each SLM pixel's light
    of each wavelength at a camera column and row; the degree is the lowest from
    ``FIELD_DEGREES[0]`` whose field series reproduces both over the field within
    ``FIELD_MISFIT_PX`` at every wavelength, at most ``FIELD_DEGREES[1]``.

    Parameters
    ----------
    desc
        The rig's description.

    Returns
    -------
    int

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> field_degree(load_rig_description("sim"))
    5
    """
    lam = np.linspace(BAND_NM[0], BAND_NM[1], FIELD_WAVELENGTHS)
    u, v, x, y = _described_streaks(desc, lam)
    positions = np.concatenate([x, y], axis=1)
    u_hat, v_hat = field_coordinates(u, v, (desc.slm.height, desc.slm.width))
    lowest, highest = FIELD_DEGREES
    for degree in range(lowest, highest + 1):
        design = legendre2d_design(u_hat, v_hat, degree)
        coeffs, *_ = np.linalg.lstsq(design, positions, rcond=None)
        if np.abs(positions - design @ coeffs).max() <= FIELD_MISFIT_PX:
            return degree
    return highest


def dispersion_order(desc: RigDescription) -> int:
    """The power of the spectral coordinate the fits need for this rig's streaks.

    At each point of the SLM field the described optics (``RigDescription.nominal_relay()``)
    put the streak's column over 400-700 nm, a polynomial in the glass index. The order is
    ``DISPERSION_ORDERS[0]`` unless that form misses some point's column by more than
    ``ORDER_MISFIT_PX``, and then one more where the rig has the lines to fit it
    (wavelength lamps, or at least ``ORDER_LASER_LINES`` lasers). The column alone
    decides: it is what the wavelength map is read from, and one more power fitted
    through lasers that stop short of the band's ends only extrapolates further.

    Parameters
    ----------
    desc
        The rig's description.

    Returns
    -------
    int

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> dispersion_order(load_rig_description("sim"))
    2
    """
    lowest, highest = DISPERSION_ORDERS
    enough_lines = bool(desc.wavelength_lamps) or len(desc.lasers_nm) >= ORDER_LASER_LINES
    if not enough_lines:
        return lowest
    lam = np.linspace(BAND_NM[0], BAND_NM[1], 61)
    _, _, x, _ = _described_streaks(desc, lam)
    index = get_glass(desc.prism.glass).index(lam)
    coordinate = (index - index.mean()) / np.ptp(index)
    for order in range(lowest, highest):
        powers = coordinate[:, None] ** np.arange(order + 1)[None, :]
        coeffs, *_ = np.linalg.lstsq(powers, x.T, rcond=None)
        if float(np.abs(x.T - powers @ coeffs).max()) <= ORDER_MISFIT_PX:
            return order
    return highest


def _filled(section: Mapping[str, Any] | None, key: str, derived: Any) -> Any:
    value = (section or {}).get(key)
    return derived if value is None else value


def planned_spectral(procedure: Mapping[str, Any], desc: RigDescription) -> dict[str, Any]:
    """The spectral procedure with every spacing it leaves out derived for this rig.

    Fills ``sweep.phase_period_px``, ``sweep.gray_block_px``, ``blur.pinhole_pitch_px``,
    ``lamps.pinhole_pitch_px``, ``fit.field_degree`` (:func:`field_degree`) and
    ``fit.dispersion_order`` (:func:`dispersion_order`) where they are ``null`` or absent;
    numbers given stay.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> proc = planned_spectral({"sweep": {}, "blur": {}}, load_rig_description("sim"))
    >>> proc["sweep"]["phase_period_px"], proc["blur"]["pinhole_pitch_px"]
    (16, [26, 26])
    >>> proc["fit"]["field_degree"], proc["fit"]["dispersion_order"]
    (5, 2)
    """
    out = copy.deepcopy(dict(procedure))
    geo = plan_geometry(desc)
    fit = out.setdefault("fit", {}) or {}
    out["fit"] = fit
    if fit.get("field_degree") is None:
        fit["field_degree"] = field_degree(desc)
    if fit.get("dispersion_order") is None:
        fit["dispersion_order"] = dispersion_order(desc)
    sweep = out.setdefault("sweep", {})
    sweep["phase_period_px"] = int(_filled(sweep, "phase_period_px", geo.phase_period))
    sweep["gray_block_px"] = int(_filled(sweep, "gray_block_px", sweep["phase_period_px"] // 2))
    blur = out.setdefault("blur", {})
    blur["pinhole_pitch_px"] = [int(p) for p in _filled(blur, "pinhole_pitch_px", geo.blur_pitch)]
    if geo.lamp_pitch is not None:
        lamps = out.setdefault("lamps", {}) or {}
        out["lamps"] = lamps
        lamps["pinhole_pitch_px"] = [
            int(p) for p in _filled(lamps, "pinhole_pitch_px", geo.lamp_pitch)
        ]
    return out


def guide_stride(desc: RigDescription) -> tuple[int, int]:
    """The guide scan's derived (horizontal, vertical) stride: every 4th pinhole offset
    along the rows on a 640 px wide SLM, in proportion below that width, at least 1.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> guide_stride(load_rig_description("sim"))  # 640 px wide; 320 px: (2, 1)
    (4, 1)
    """
    across = GUIDE_STRIDE * desc.slm.width // GUIDE_STRIDE_WIDTH
    return max(1, min(GUIDE_STRIDE, across)), 1


def planned_guide(procedure: Mapping[str, Any], desc: RigDescription) -> dict[str, Any]:
    """The guide procedure with its scan stride, its scan pitch (a multiple of the stride)
    and its inlier count derived where ``null``.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> proc = planned_guide({"scan": {"stride_px": None}, "tolerances": {}},
    ...                      load_rig_description("sim"))
    >>> proc["scan"]["stride_px"], proc["scan"]["pitch_px"], proc["tolerances"]["min_inliers"]
    ([4, 1], [100, 5], 30)
    """
    out = copy.deepcopy(dict(procedure))
    scan = out.setdefault("scan", {})
    stride = tuple(int(s) for s in (scan.get("stride_px") or guide_stride(desc)))
    scan["stride_px"] = list(stride)
    scan["pitch_px"] = list(scan_pitch(desc, scan.get("pitch_px"), stride))
    tol = out.setdefault("tolerances", {})
    tol["min_inliers"] = int(_filled(tol, "min_inliers", plan_geometry(desc).min_inliers))
    return out


def planned_macbeth(procedure: Mapping[str, Any], desc: RigDescription) -> dict[str, Any]:
    """A procedure with a ``scan.pitch_px`` (Macbeth, snapshot validation) derived where
    ``null``.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> planned_macbeth({"scan": {"pitch_px": None}}, load_rig_description("sim"))["scan"]
    {'pitch_px': [100, 5]}
    """
    out = copy.deepcopy(dict(procedure))
    scan = out.setdefault("scan", {})
    scan["pitch_px"] = list(scan_pitch(desc, scan.get("pitch_px")))
    return out


def planned_health_check(procedure: Mapping[str, Any], desc: RigDescription) -> dict[str, Any]:
    """The health check's procedure with its lamp pinhole pitch derived where ``null``
    (the calibration's lamp pitch).

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> planned_health_check({"pinhole_pitch_px": None}, load_rig_description("sim"))
    {'pinhole_pitch_px': [87, 24]}
    """
    out = copy.deepcopy(dict(procedure))
    geo = plan_geometry(desc)
    if out.get("pinhole_pitch_px") is None and geo.lamp_pitch is not None:
        out["pinhole_pitch_px"] = list(geo.lamp_pitch)
    return out
