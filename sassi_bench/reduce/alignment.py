"""Alignment readings from frames of a sparse pinhole pattern: what a person aligns a bench by.

Device-free: the readings take frames (arrays) and the rig's description, so the
``sassi-bench align`` command, a live view and a notebook compute them the same way.
Each :class:`Reading` has a value, its target from the description and advice:

- **focus**: spot widths per laser wavelength against the line spread the rig's
  described blur gives (``blur.sigma_px`` with the SLM pixel's aperture), and the
  wavelength of best focus (a quadratic through the spot widths, the PSF's form in the
  SASSI paper) against the described one: a camera moved along the axis brings another
  wavelength to focus, so the sign says which way to turn;
- **streak roll**: the angle of the streaks of a broadband light against the camera
  rows, each streak's column centroids fitted by a line, against the angle the described
  optics give (the prism's designed smile);
- **footprint**: where the SLM's image lands (its corners at a laser line, through an
  affine map fitted to the pinholes' spots matched to the described relay's positions),
  the shift from the design and the margins to the sensor's edges;
- **exposure**: the brightest pixels as a share of full scale and the saturated share.

Examples
--------
>>> from sassi_bench.rig import load_rig_description
>>> alignment_pattern(load_rig_description("sim"))
{'kind': 'pinholes', 'pitch': [76, 24], 'offset': [38, 12]}
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.spatial import cKDTree

from sassi_bench.acquire.patterns import open_pixels
from sassi_bench.optics.psf import PsfSigmaCurve, line_spread_sigma
from sassi_bench.rig.config import RigDescription

__all__ = [
    "Reading",
    "alignment_pattern",
    "alignment_readings",
    "exposure_reading",
    "find_spots",
    "focus_readings",
    "footprint_reading",
    "laser_roll_reading",
    "match_spots",
    "roll_reading",
    "streak_angles",
]

#: The brightest pixels of a frame should sit between these shares of full scale.
EXPOSURE_TARGET = (0.3, 0.85)
#: Best focus within this many nm of the design reads as in focus.
FOCUS_TOLERANCE_NM = 5.0
#: A streak roll within this many degrees of the design reads as aligned.
ROLL_TOLERANCE_DEG = 0.05
#: A footprint within this many camera px of the design reads as aligned.
FOOTPRINT_TOLERANCE_PX = 2.0


@dataclass(frozen=True)
class Reading:
    """One alignment reading: a value, its target, whether it is met and what to do.

    Examples
    --------
    >>> print(Reading("streak roll", "0.71 deg", "0.67 deg", True, "aligned").line())
      ok    streak roll              0.71 deg      target 0.67 deg: aligned
    """

    name: str
    value: str
    target: str
    ok: bool
    advice: str
    numbers: tuple[float, ...] = ()

    def line(self) -> str:
        """The reading as one printed line."""
        mark = "ok  " if self.ok else "TURN"
        return f"  {mark}  {self.name:24s} {self.value:13s} target {self.target}: {self.advice}"


def alignment_pattern(desc: RigDescription) -> dict[str, Any]:
    """Sparse pinholes whose streaks do not touch: the pitch along x spans a streak and
    its blur, along y ten widths of the widest spot.

    Examples
    --------
    >>> from sassi_bench.rig import load_rig_description
    >>> alignment_pattern(load_rig_description("lab-example"))["pitch"]
    [82, 24]
    """
    widest = max(desc.blur.sigma_px.values())
    scale = desc.relay.scale
    px = math.ceil((desc.prism.spread_px + 8 * widest) / scale)
    py = max(math.ceil(14 * widest / scale), 24)
    return {"kind": "pinholes", "pitch": [px, py], "offset": [px // 2, py // 2]}


def _background(frame: NDArray[Any]) -> tuple[float, float]:
    """The frame's background level and noise (median, scaled MAD)."""
    data = frame.astype(np.float64, copy=False)
    level = float(np.median(data))
    noise = 1.4826 * float(np.median(np.abs(data - level)))
    return level, max(noise, 0.5)


def _mono(frame: NDArray[Any]) -> NDArray[np.float64]:
    data = np.asarray(frame, dtype=np.float64)
    return data.mean(axis=-1) if data.ndim == 3 else data


def find_spots(
    frame: NDArray[Any], radius: int = 6, rel_threshold: float = 0.15
) -> dict[str, NDArray[np.float64]]:
    """Isolated spots of a laser pinhole frame: centroid and second-moment widths.

    Each spot is measured in a (2 radius + 1) square window about its peak, above the
    frame's background (a spot whose window leaves the frame is dropped).

    Returns
    -------
    dict
        ``x``, ``y`` (camera px), ``sigma_x``, ``sigma_y`` (px), ``flux`` (ADU), one
        value per spot.

    Examples
    --------
    >>> yy, xx = np.mgrid[0:40, 0:40]
    >>> spot = 100 + 1000 * np.exp(-((xx - 20.3) ** 2 + (yy - 15.0) ** 2) / (2 * 1.5**2))
    >>> s = find_spots(spot)
    >>> round(float(s["x"][0]), 2), round(float(s["sigma_x"][0]), 1)
    (20.3, 1.5)
    """
    data = _mono(frame)
    level, noise = _background(data)
    above = data - level
    peak = float(above.max())
    threshold = max(6 * noise, rel_threshold * peak)
    labels, count = ndimage.label(above > threshold)
    empty = np.zeros(0)
    if count == 0:
        return dict(x=empty, y=empty, sigma_x=empty, sigma_y=empty, flux=empty)
    peaks = np.array(ndimage.maximum_position(above, labels, np.arange(1, count + 1)))
    h, w = data.shape
    inside = (
        (peaks[:, 0] >= radius)
        & (peaks[:, 0] < h - radius)
        & (peaks[:, 1] >= radius)
        & (peaks[:, 1] < w - radius)
    )
    peaks = peaks[inside]
    offsets = np.arange(-radius, radius + 1)
    rows = peaks[:, 0, None, None] + offsets[None, :, None]
    cols = peaks[:, 1, None, None] + offsets[None, None, :]
    windows = above[rows, cols]  # (spots, 2r+1, 2r+1)
    flux = windows.sum(axis=(1, 2))
    dy = offsets[None, :, None].astype(np.float64)
    dx = offsets[None, None, :].astype(np.float64)
    mx = (windows * dx).sum(axis=(1, 2)) / flux
    my = (windows * dy).sum(axis=(1, 2)) / flux
    vx = (windows * (dx - mx[:, None, None]) ** 2).sum(axis=(1, 2)) / flux
    vy = (windows * (dy - my[:, None, None]) ** 2).sum(axis=(1, 2)) / flux
    good = (flux > 0) & (vx > 0) & (vy > 0)
    return {
        "x": (peaks[:, 1] + mx)[good],
        "y": (peaks[:, 0] + my)[good],
        "sigma_x": np.sqrt(vx[good]),
        "sigma_y": np.sqrt(vy[good]),
        "flux": flux[good],
    }


def streak_angles(frame: NDArray[Any], rel_threshold: float = 0.1) -> NDArray[np.float64]:
    """The angle (degrees, against the camera rows) of each streak of a broadband
    pinhole frame: a weighted line through its columns' row centroids.

    Examples
    --------
    >>> yy, xx = np.mgrid[0:60, 0:120]
    >>> line = 30 + np.tan(np.deg2rad(1.0)) * (xx - 60)
    >>> frame = 100 + 800 * np.exp(-((yy - line) ** 2) / 2) * ((xx > 20) & (xx < 100))
    >>> round(float(streak_angles(frame)[0]), 3)
    1.0
    """
    data = _mono(frame)
    level, noise = _background(data)
    above = data - level
    mask = above > max(6 * noise, rel_threshold * float(above.max()))
    mask = ndimage.binary_dilation(mask, iterations=2)
    labels, count = ndimage.label(mask)
    if count == 0:
        return np.zeros(0)
    rows, cols = np.nonzero(labels)
    lab = labels[rows, cols]
    weight = np.clip(above[rows, cols], 0.0, None)
    w = data.shape[1]
    # Per (streak, column): weight and weighted row, then each column's centroid.
    key = lab.astype(np.int64) * w + cols
    uniq, inverse = np.unique(key, return_inverse=True)
    col_w = np.bincount(inverse, weight)
    col_y = np.bincount(inverse, weight * rows) / np.maximum(col_w, 1e-12)
    col_lab = uniq // w
    col_x = (uniq % w).astype(np.float64)
    # Weighted line fit per streak: y = a + b x.
    n = count + 1
    sw = np.bincount(col_lab, col_w, n)
    sx = np.bincount(col_lab, col_w * col_x, n)
    sy = np.bincount(col_lab, col_w * col_y, n)
    sxx = np.bincount(col_lab, col_w * col_x**2, n)
    sxy = np.bincount(col_lab, col_w * col_x * col_y, n)
    width = np.bincount(col_lab, None, n)
    denom = sw * sxx - sx**2
    long_enough = (width >= 10) & (denom > 0)
    long_enough[0] = False
    slope = (sw * sxy - sx * sy)[long_enough] / denom[long_enough]
    return np.rad2deg(np.arctan(slope))


def designed_streak_angle(desc: RigDescription, pattern: dict[str, Any]) -> float:
    """The streak angle (degrees) the described optics give at the pattern's pinholes."""
    grid = desc.spectral_grid
    lam = np.arange(max(grid.start_nm, 420.0), min(grid.stop_nm, 680.0) + 1e-9, 10.0)
    return _relay_streak_angle(
        desc.nominal_relay(), pattern, (desc.slm.height, desc.slm.width), lam
    )


def _relay_streak_angle(relay: Any, pattern: dict[str, Any], shape: tuple[int, int], lam) -> float:
    rows, cols = open_pixels(pattern, shape)
    x, y = relay.forward(cols[:, None], rows[:, None], lam[None, :])
    xm = x - x.mean(axis=1, keepdims=True)
    slope = (xm * (y - y.mean(axis=1, keepdims=True))).sum(axis=1) / (xm**2).sum(axis=1)
    return float(np.median(np.rad2deg(np.arctan(slope))))


def roll_reading(desc: RigDescription, pattern: dict[str, Any], frame: NDArray[Any]) -> Reading:
    """Streak roll of a broadband pinhole frame against the design."""
    angles = streak_angles(frame)
    target = designed_streak_angle(desc, pattern)
    if angles.size < 3:
        return Reading(
            "streak roll broadband",
            "no streaks",
            f"{target:.3f} deg",
            False,
            "switch on a broadband light (LED, halogen) and open the shutter",
        )
    return _roll(float(np.median(angles)), target, "broadband")


def focus_readings(desc: RigDescription, frames: dict[float, NDArray[Any]]) -> list[Reading]:
    """Spot widths per laser wavelength against the described blur, and best focus.

    Parameters
    ----------
    desc
        The rig description.
    frames
        Laser pinhole frames by wavelength (nm).
    """
    described = PsfSigmaCurve(desc.blur.sigma_px)
    scale, fill = desc.relay.scale, desc.slm.fill_factor
    aperture2 = ((fill * scale) ** 2 + 1.0) / 12.0
    out = []
    lam, psf = [], []
    for nm in sorted(frames):
        target = float(line_spread_sigma(described(nm), scale, fill))
        # A window of +-4 designed widths: the noise of a wider one biases the moments.
        spots = find_spots(frames[nm], radius=max(3, math.ceil(4 * target)))
        if spots["x"].size < 3:
            out.append(Reading(f"focus {nm:g} nm", "no spots", "", False, "check the laser is on"))
            continue
        width = float(np.median(0.5 * (spots["sigma_x"] + spots["sigma_y"])))
        ok = width <= 1.15 * target
        out.append(
            Reading(
                f"spot width {nm:g} nm",
                f"{width:.2f} px",
                f"{target:.2f} px",
                ok,
                "as designed" if ok else f"{width / target:.2f}x the designed width: refocus",
                (width, target),
            )
        )
        lam.append(nm)
        psf.append(math.sqrt(max(width**2 - aperture2, 0.01)))
    if len(lam) >= 3:
        grid = np.linspace(min(lam) - 50, max(lam) + 50, 2001)
        designed_best = float(grid[np.argmin(described(grid))])
        a, b, _ = np.polyfit(np.asarray(lam), np.asarray(psf), 2)
        best = -b / (2 * a) if a > 0 else float("nan")
        shift = best - designed_best
        ok = bool(np.isfinite(best) and abs(shift) <= FOCUS_TOLERANCE_NM)
        if not np.isfinite(best):
            advice = "no focus minimum between the lasers: refocus coarsely first"
        elif ok:
            advice = "in focus"
        else:
            toward = "blue (shorter)" if shift > 0 else "red (longer)"
            advice = f"refocus so best focus moves {abs(shift):.0f} nm to the {toward} wavelengths"
        out.append(
            Reading(
                "best focus",
                f"{best:.0f} nm" if np.isfinite(best) else "none",
                f"{designed_best:.0f} nm",
                ok,
                advice,
                (best, designed_best),
            )
        )
    return out


def match_spots(
    desc: RigDescription, pattern: dict[str, Any], frame: NDArray[Any], wavelength_nm: float
) -> tuple[NDArray[np.intp], NDArray[np.float64], NDArray[np.float64]]:
    """The laser spots of a pinhole frame matched to the pattern's pinholes.

    Returns
    -------
    index
        The pinhole (in :func:`~sassi_bench.acquire.patterns.open_pixels` order) of each
        matched spot.
    measured
        Their camera positions, (n, 2) x and y.
    designed
        Every pinhole's position by the described relay, (pinholes, 2).
    """
    shape = (desc.slm.height, desc.slm.width)
    rows, cols = open_pixels(pattern, shape)
    px, py = desc.nominal_relay().forward(cols.astype(float), rows.astype(float), wavelength_nm)
    designed = np.column_stack([px, py])
    spots = find_spots(frame)
    measured = np.column_stack([spots["x"], spots["y"]])
    if measured.shape[0] < 6:
        return np.zeros(0, np.intp), np.zeros((0, 2)), designed
    shift = _coarse_shift(measured, designed, pattern)
    reach = 0.3 * min(pattern["pitch"]) * desc.relay.scale
    dist, index = cKDTree(designed + shift).query(measured, distance_upper_bound=reach)
    matched = np.isfinite(dist)
    return index[matched], measured[matched], designed


def laser_roll_reading(
    desc: RigDescription,
    pattern: dict[str, Any],
    blue: tuple[float, NDArray[Any]],
    red: tuple[float, NDArray[Any]],
) -> Reading:
    """Streak roll from two laser lines: the angle of the chord from each pinhole's
    shorter-wavelength spot to its longer-wavelength one, against the design's."""
    (nm_a, frame_a), (nm_b, frame_b) = blue, red
    ia, pa, design_a = match_spots(desc, pattern, frame_a, nm_a)
    ib, pb, design_b = match_spots(desc, pattern, frame_b, nm_b)
    common, ka, kb = np.intersect1d(ia, ib, return_indices=True)
    if common.size < 3:
        return Reading(
            "streak roll", "no spots", "", False, "switch on two lasers far apart in wavelength"
        )
    d = pb[kb] - pa[ka]
    value = float(np.median(np.rad2deg(np.arctan2(d[:, 1], d[:, 0]))))
    dd = design_b[common] - design_a[common]
    target = float(np.median(np.rad2deg(np.arctan2(dd[:, 1], dd[:, 0]))))
    return _roll(value, target, f"{nm_a:g}-{nm_b:g} nm")


def _roll(value: float, target: float, what: str) -> Reading:
    error = value - target
    ok = abs(error) <= ROLL_TOLERANCE_DEG
    turn = "clockwise" if error > 0 else "anticlockwise"
    advice = (
        "aligned"
        if ok
        else f"roll the prism {abs(error):.2f} deg {turn} as the camera image shows it (rows down)"
    )
    return Reading(
        f"streak roll {what}", f"{value:.3f} deg", f"{target:.3f} deg", ok, advice, (value, target)
    )


def footprint_reading(
    desc: RigDescription, pattern: dict[str, Any], frame: NDArray[Any], wavelength_nm: float
) -> Reading:
    """Where the SLM's image lands at a laser line: corners, shift and margins."""
    index, measured, designed = match_spots(desc, pattern, frame, wavelength_nm)
    if index.size < 6:
        return Reading(
            f"footprint {wavelength_nm:g} nm",
            "no spots",
            "0,0 px",
            False,
            "check the laser and that the SLM's image reaches the camera",
        )
    src = np.column_stack([designed[index], np.ones(index.size)])
    affine, *_ = np.linalg.lstsq(src, measured, rcond=None)
    h, w = desc.slm.height, desc.slm.width
    cu = np.array([-0.5, w - 0.5, w - 0.5, -0.5])
    cv = np.array([-0.5, -0.5, h - 0.5, h - 0.5])
    dx, dy = desc.nominal_relay().forward(cu, cv, wavelength_nm)
    design = np.column_stack([dx, dy])
    corners = np.column_stack([design, np.ones(4)]) @ affine
    offset = (corners - design).mean(axis=0)
    ch, cw = desc.spectral_camera.height, desc.spectral_camera.width
    margins = (
        corners[:, 0].min() + 0.5,
        cw - 0.5 - corners[:, 0].max(),
        corners[:, 1].min() + 0.5,
        ch - 0.5 - corners[:, 1].max(),
    )
    ok = float(np.hypot(*offset)) <= FOOTPRINT_TOLERANCE_PX and min(margins) > 0
    advice = (
        "aligned"
        if ok
        else f"move the SLM's image {-offset[0]:+.1f} px in x and {-offset[1]:+.1f} px in y "
        "on the camera (relay or camera mount)"
    )
    return Reading(
        f"footprint {wavelength_nm:g} nm",
        f"{offset[0]:+.1f},{offset[1]:+.1f} px",
        "0,0 px",
        ok,
        f"{advice}; margins left/right/top/bottom " + "/".join(f"{m:.0f}" for m in margins) + " px",
        (*corners.ravel(), *offset),
    )


def _coarse_shift(
    measured: NDArray[np.float64], predicted: NDArray[np.float64], pattern: dict[str, Any]
) -> NDArray[np.float64]:
    """The shift that matches most spots to the design (a vote over spot differences
    within one pitch; the image may be off by more than a spot's width)."""
    diffs = (measured[:, None, :] - predicted[None, :, :]).reshape(-1, 2)
    reach = 0.5 * max(pattern["pitch"]) * 1.5
    diffs = diffs[np.all(np.abs(diffs) < reach, axis=1)]
    if diffs.size == 0:
        return np.zeros(2)
    hist, xe, ye = np.histogram2d(diffs[:, 0], diffs[:, 1], bins=int(2 * reach))
    i, j = np.unravel_index(np.argmax(hist), hist.shape)
    centre = np.array([(xe[i] + xe[i + 1]) / 2, (ye[j] + ye[j + 1]) / 2])
    near = diffs[np.all(np.abs(diffs - centre) < 2.0, axis=1)]
    return near.mean(axis=0) if near.size else centre


def exposure_reading(name: str, frame: NDArray[Any], bit_depth: int) -> Reading:
    """The brightest pixels and the saturated share of a frame against the target."""
    data = np.asarray(frame)
    full = float((1 << bit_depth) - 1)
    saturated = float(np.count_nonzero(data >= full)) / data.size
    peak = float(np.percentile(data, 99.99)) / full
    lo, hi = EXPOSURE_TARGET
    if saturated > 0:
        ok, advice = False, f"{100 * saturated:.3f} % saturated: shorten the exposure"
    elif peak > hi:
        ok, advice = False, "close to saturation: shorten the exposure"
    elif peak < lo:
        ok, advice = False, "dim: lengthen the exposure or brighten the light"
    else:
        ok, advice = True, "no saturated pixels"
    return Reading(
        f"exposure {name}",
        f"{100 * peak:.0f} %",
        f"{100 * lo:.0f}-{100 * hi:.0f} % of full scale",
        ok,
        advice,
        (peak, saturated),
    )


def alignment_readings(
    desc: RigDescription,
    pattern: dict[str, Any],
    frames: dict[str, NDArray[Any]],
    bit_depth: int,
) -> list[Reading]:
    """Every reading the frames allow, in the order a person aligns by.

    Parameters
    ----------
    desc
        The rig description.
    pattern
        The pinhole pattern on the SLM (:func:`alignment_pattern`).
    frames
        Spectral frames by light name (``"laser:532"``, ``"led"`` ...).
    bit_depth
        The spectral camera's bits, for the exposure readings.

    Returns
    -------
    list of Reading
        Focus (lasers), streak roll (two lasers far apart, else a broadband light),
        footprint (the laser nearest the prism's reference wavelength), exposure (every
        frame).
    """
    lasers = {
        float(name.split(":", 1)[1]): frame
        for name, frame in frames.items()
        if name.startswith("laser:")
    }
    broadband = [name for name in frames if not name.startswith(("laser:", "lamp:", "off"))]
    out: list[Reading] = []
    if lasers:
        out += focus_readings(desc, lasers)
    if len(lasers) >= 2:
        lo, hi = min(lasers), max(lasers)
        out.append(laser_roll_reading(desc, pattern, (lo, lasers[lo]), (hi, lasers[hi])))
    elif broadband:
        out.append(roll_reading(desc, pattern, frames[broadband[0]]))
    if lasers:
        nearest = min(lasers, key=lambda nm: abs(nm - desc.prism.reference_nm))
        out.append(footprint_reading(desc, pattern, lasers[nearest], nearest))
    out += [exposure_reading(name, frame, bit_depth) for name, frame in frames.items()]
    return out
