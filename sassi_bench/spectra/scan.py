"""Nyquist pinhole scans (reference cubes): the plan, and streaming assembly into a cube.

A Nyquist pinhole scan opens SLM pixels on a grid (100 px apart horizontally, 5 px
vertically by default) and shifts it through every offset, so every SLM pixel is open
in exactly one of the 100 x 5 = 500 frames. Assembly streams the frames from the
session twice, one frame in memory at a time:

1. **Offset.** Every frame carries the same smooth background (closed pixels leak
   ``1/contrast`` of the light; plus the dark level). A camera pixel outside the
   predicted streak footprints of a frame sees only that background, and across the
   shifted frames every camera pixel is free in dozens of frames, so the background is
   averaged per pixel over those frames. No closed-SLM frame is needed (one, when the
   plan has it, only checks the estimate).
2. **Spectra.** Each frame minus the background is extracted at the bundle's bins
   (:func:`~sassi_bench.spectra.extract.extract_spectra`) and the spectra land in the
   cube at their SLM pixels. Frames with NaNs or the wrong shape, and streaks that are
   saturated or leave the camera, are reported by frame and SLM pixel and flagged in a
   quality mask instead of being filled in.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.patterns import render_pattern
from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import step_error
from sassi_bench.spectra.extract import (
    SpectralDeblur,
    StreakGeometry,
    extract_spectra,
    streak_geometry,
)
from sassi_bench.spectra.offset import estimate_background, streak_footprint

__all__ = ["QUALITY_FLAGS", "ScanCube", "assemble_scan", "scan_plan"]

#: Bits of the quality mask.
QUALITY_FLAGS = {"not_measured": 1, "off_camera": 2, "saturated": 4, "bad_frame": 8}


def scan_plan(
    slm_shape: tuple[int, int],
    light: str,
    exposure_s: float,
    pitch: tuple[int, int] = (100, 5),
    scene: str | None = None,
    closed_check: bool = True,
) -> Plan:
    """The pinhole scan: every offset of a ``pitch`` grid, one frame each.

    Examples
    --------
    >>> plan = scan_plan((400, 640), "led", 0.1)
    >>> len(plan.select(role="pinholes")), plan.steps[0].tags["role"]
    (500, 'closed')
    """
    px, py = int(pitch[0]), int(pitch[1])
    steps = []
    if closed_check:
        steps.append(Step("spectral", light, exposure_s, {"kind": "blank"}, {"role": "closed"}))
    for oy in range(py):
        for ox in range(px):
            pattern = {"kind": "pinholes", "pitch": [px, py], "offset": [ox, oy]}
            steps.append(
                Step(
                    "spectral", light, exposure_s, pattern, {"role": "pinholes", "ox": ox, "oy": oy}
                )
            )
    parameters = {"pitch": [px, py], "light": light, "exposure_s": exposure_s}
    if scene is not None:
        parameters["scene"] = scene
    return Plan("pinhole-scan", tuple(steps), parameters)


@dataclass
class ScanCube:
    """An assembled scan: signal per second per bin on the SLM grid, and its quality.

    Attributes
    ----------
    cube
        (H, W, B) float32, camera units per second (divide by a response for radiance).
    quality
        (H, W) uint8 bit mask (:data:`QUALITY_FLAGS`); 0 = good.
    wavelengths_nm, bin_edges_nm
        The bundle's bins.
    origin
        (row, column) of the cube's first pixel on the SLM (an ROI's corner).
    background
        The background estimate (H_cam, W_cam) in camera units.
    background_check_rms
        RMS difference between the estimate and the closed-SLM frame, if one was taken.
    problems
        One line per frame or pixel problem (frame index, SLM pixel, cause).
    """

    cube: NDArray[np.float32]
    quality: NDArray[np.uint8]
    wavelengths_nm: NDArray[np.float64]
    bin_edges_nm: NDArray[np.float64]
    origin: tuple[int, int]
    background: NDArray[np.float64]
    background_check_rms: float | None
    mean_streak_signal: float
    problems: list[str] = field(default_factory=list)


def _open_pixels(step: Step, slm_shape, roi) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    rows, cols = np.nonzero(render_pattern(step.pattern, slm_shape))
    if roi is not None:
        r0, c0, r1, c1 = roi
        keep = (rows >= r0) & (rows < r1) & (cols >= c0) & (cols < c1)
        rows, cols = rows[keep], cols[keep]
    return rows, cols


def _frame(session: Session, index: int, shape, problems: list[str]) -> NDArray[np.float64] | None:
    data = np.asarray(session.read_frame(index), dtype=np.float64)
    if data.shape != shape:
        problems.append(f"frame {index}: shape {data.shape}, expected {shape}; frame skipped")
        return None
    return data


def _background(session, bundle, steps: Iterable[int], slm_shape, camera_shape, progress):
    total = np.zeros(camera_shape)
    count = np.zeros(camera_shape)
    scratch: list[str] = []
    for index in _progress(steps, "scan offset", progress):
        data = _frame(session, index, camera_shape, scratch)
        if data is None:
            continue
        rows, cols = _open_pixels(session.plan.steps[index], slm_shape, None)
        free = ~streak_footprint(streak_geometry(bundle, rows, cols), camera_shape)
        free &= np.isfinite(data)
        total += np.where(free, data, 0.0)
        count += free
    background = np.divide(total, count, out=np.full(camera_shape, np.nan), where=count > 0)
    if np.isnan(background).any():  # pixels never free: fill from their surroundings
        known = ~np.isnan(background)
        filled = estimate_background(np.nan_to_num(background), ~known)
        background = np.where(known, background, filled.image)
    return background, count


def _progress(items, label: str, enabled: bool):
    if not enabled:
        return items
    from tqdm.auto import tqdm

    items = list(items)
    return tqdm(items, desc=label, unit="frame")


def assemble_scan(
    session: Session,
    bundle: CalibrationBundle,
    *,
    roi: tuple[int, int, int, int] | None = None,
    deblur: bool = True,
    progress: bool = True,
) -> ScanCube:
    """Assemble a pinhole-scan session into a cube on the SLM grid.

    Parameters
    ----------
    session
        A session captured from :func:`scan_plan` (complete or not: missing frames leave
        their pixels flagged ``not_measured``).
    bundle
        The calibration bundle giving the streak geometry and blur.
    roi
        Optional (row0, col0, row1, col1) SLM region (end exclusive) to assemble.
    deblur
        Undo the spill of each bin into its neighbours along the streak (see
        :mod:`sassi_bench.spectra.extract`).

    Returns
    -------
    ScanCube
    """
    rig = session.rig
    slm_shape = (int(rig["slm"]["height"]), int(rig["slm"]["width"]))
    camera_shape = (int(rig["spectral_camera"]["height"]), int(rig["spectral_camera"]["width"]))
    saturation = 2 ** int(rig["spectral_camera"]["bit_depth"]) - 1
    if tuple(bundle.slm_shape) != slm_shape:
        raise ValueError(
            step_error(
                "scan assembly",
                f"the bundle is for a {bundle.slm_shape} SLM, the session's rig has {slm_shape}",
                "load the bundle of the rig the scan was taken on",
            )
        )
    unmix = SpectralDeblur.from_bundle(bundle, full_scale=saturation) if deblur else None
    r0, c0, r1, c1 = roi if roi is not None else (0, 0, *slm_shape)
    n_bins = bundle.wavelengths.size
    cube = np.zeros((r1 - r0, c1 - c0, n_bins), dtype=np.float32)
    quality = np.full((r1 - r0, c1 - c0), QUALITY_FLAGS["not_measured"], dtype=np.uint8)
    steps = [i for i in session.plan.select(role="pinholes") if i in session.completed]
    problems: list[str] = []
    background, _ = _background(session, bundle, steps, slm_shape, camera_shape, progress)
    check = None
    closed = [i for i in session.plan.select(role="closed") if i in session.completed]
    if closed:
        check = float(np.sqrt(np.mean((session.read_frame(closed[0]) - background) ** 2)))
    signal_sum, signal_count = 0.0, 0
    for index in _progress(steps, "scan spectra", progress):
        step = session.plan.steps[index]
        rows, cols = _open_pixels(step, slm_shape, roi)
        if rows.size == 0:
            continue
        data = _frame(session, index, camera_shape, problems)
        local = (rows - r0, cols - c0)
        if data is None:
            quality[local] = QUALITY_FLAGS["bad_frame"]
            continue
        geo = streak_geometry(bundle, rows, cols)
        spectra, off = extract_spectra(data - background, geo, unmix)
        flags = np.where(off.any(axis=1), QUALITY_FLAGS["off_camera"], 0).astype(np.uint8)
        flags |= _pixel_flags(data, geo, saturation, index, problems)
        cube[local] = (spectra / step.exposure_s).astype(np.float32)
        quality[local] = flags
        good = flags == 0
        signal_sum += float(spectra[good].sum())
        signal_count += int(good.sum()) * n_bins
    return ScanCube(
        cube=cube,
        quality=quality,
        wavelengths_nm=np.asarray(bundle.wavelengths),
        bin_edges_nm=np.asarray(bundle.bin_edges),
        origin=(r0, c0),
        background=background,
        background_check_rms=check,
        mean_streak_signal=signal_sum / max(signal_count, 1),
        problems=problems,
    )


def _pixel_flags(data, geo: StreakGeometry, saturation: int, index: int, problems: list[str]):
    """Saturated or non-finite pixels under each open pixel's streak."""
    h, w = data.shape
    x0 = np.clip(np.floor(geo.x_left.min(axis=1)).astype(np.intp), 0, w - 1)
    x1 = np.clip(np.ceil(geo.x_right.max(axis=1)).astype(np.intp), 0, w - 1)
    y = np.clip(np.rint(geo.y.mean(axis=1)).astype(np.intp), 0, h - 1)
    bad = (data >= saturation) | ~np.isfinite(data)
    # Any bad pixel on the streak's centre row segment (cumulative sums per row).
    cum = np.concatenate([np.zeros((h, 1)), np.cumsum(bad, axis=1)], axis=1)
    hit = (cum[y, x1 + 1] - cum[y, x0]) > 0
    flags = np.where(hit, QUALITY_FLAGS["saturated"], 0).astype(np.uint8)
    for r, c in zip(geo.rows[hit][:5], geo.cols[hit][:5], strict=True):
        problems.append(
            f"frame {index}: streak of SLM pixel (u={c}, v={r}) is saturated or not finite"
        )
    if hit.sum() > 5:
        problems.append(f"frame {index}: {int(hit.sum()) - 5} more saturated streaks")
    return flags
