"""What the spectral calibration's sessions measure, read back from their frames.

The grey-level session gives the SLM's grey-level response
(:func:`measure_response`); the sweep session gives every laser's camera <-> SLM
correspondences and their smooth field maps (:func:`analyse_sweep`, structured light
or the paper's line sweep) and the blur from its pinhole frames
(:func:`blur_from_pinholes`). Frames are selected by the tags of the plans in
:mod:`sassi_bench.acquire.spectral_plans`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.patterns import open_pixels
from sassi_bench.acquire.session import Session
from sassi_bench.calibrate.blur import (
    BlurFit,
    SpotMoments,
    fit_blur,
    fit_field_covariance,
    measure_spot_widths,
)
from sassi_bench.calibrate.dispersion import DispersionFit, LaserMap
from sassi_bench.calibrate.field import fit_field
from sassi_bench.calibrate.grey_response import GreyResponse, measure_grey_response
from sassi_bench.calibrate.line_sweep import fit_line_axis, line_centres
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.reduce.sweep_stream import (
    DecodedSweep,
    PinholeSignal,
    SweepDecode,
    SweepStream,
    lit_pixels,
)
from sassi_bench.rig.config import RigDescription

__all__ = [
    "LaserDecode",
    "SweepDecode",
    "analyse_sweep",
    "blur_form",
    "blur_from_pinholes",
    "excluded_regions",
    "measure_response",
    "pinhole_signal",
    "slm_pixel_image_px",
]


@dataclass(frozen=True)
class LaserDecode:
    """What one laser's sweep gave: correspondences, their smooth map, and counts."""

    wavelength_nm: float
    camera_x: NDArray[np.float64]
    camera_y: NDArray[np.float64]
    slm_u: NDArray[np.float64]
    slm_v: NDArray[np.float64]
    valid_fraction: float
    counts: dict[str, int]
    laser_map: LaserMap
    residual_rms_px: float
    """Scatter of the raw measurements about the smooth map, camera px: decoded pixels
    about the field fit (structured), line centres about their fits (lines)."""


def _frames(session: Session, indices: list[int]) -> NDArray[np.float32]:
    return session.read_frames(indices).astype(np.float32)


def _one(session: Session, **tags) -> NDArray[np.float32]:
    indices = session.plan.select(**tags)
    if not indices:
        raise ProcedureError(
            step_error("spectral analysis", f"no frame tagged {tags}", "re-run the capture")
        )
    return _frames(session, indices).mean(axis=0)


def measure_response(session: Session, saturation: float) -> GreyResponse:
    """The SLM's grey-level response from a grey-level session.

    Parameters
    ----------
    session
        A session of :func:`~sassi_bench.acquire.spectral_plans.grey_plan`.
    saturation
        Raw value at which the spectral camera saturates.

    Returns
    -------
    GreyResponse

    Examples
    --------
    Not run here (it needs captured sessions)::

        response = measure_response(sweeps.grey, saturation=65535)
    """
    plan = session.plan
    indices = plan.select(role="grey")
    levels = [plan.steps[i].tags["level"] for i in indices]
    dark = _one(session, role="dark")
    # The raw frames (uint16): measure_grey_response converts one frame at a time.
    return measure_grey_response(
        levels, session.read_frames(indices), dark, saturation_level=saturation
    )


def _structured_decode(
    session: Session, proc, laser: float, slm_shape, saturation: float
) -> SweepDecode:
    """One laser's structured sweep decoded from its session, frame by frame (as
    :class:`~sassi_bench.reduce.sweep_stream.SweepStream` decodes it during a capture)."""
    stream = SweepStream(session.plan, proc, slm_shape, saturation, {laser}, pinholes=False)
    for index in stream.steps:
        stream.add(index, session.read_frame(index))
    decoded = stream.result().decodes.get(laser)
    if decoded is None:
        raise ProcedureError(
            step_error(
                f"sweep decoding at {laser:g} nm",
                "the session has no complete structured sweep of this laser",
                "re-run the capture",
            )
        )
    return decoded


def _line_decode(session: Session, proc, laser: float, slm_shape, saturation: float) -> SweepDecode:
    sweep = proc["sweep"]
    plan = session.plan
    blank = _one(session, role="blank", laser=laser)
    full = _one(session, role="full", laser=laser)
    camera_shape = blank.shape
    fits = {}
    skipped = 0
    for axis, length in (("x", slm_shape[1]), ("y", slm_shape[0])):
        indices = plan.select(role="line", laser=laser, axis=axis)
        offsets = [plan.steps[i].tags["offset"] for i in indices]
        signals = [session.read_frame(i).astype(np.float32) - blank for i in indices]
        centres = line_centres(
            signals, offsets, int(sweep.get("line_spacing_px", 64)), axis, length
        )
        skipped += centres.skipped_frames
        fits[axis] = fit_line_axis(centres, camera_shape, int(proc["fit"].get("field_degree", 5)))
    lit = lit_pixels(full, blank)
    rows, cols = np.nonzero(lit)
    x, y = cols.astype(np.float64), rows.astype(np.float64)
    u, v = fits["x"](x, y), fits["y"](x, y)
    inside = (u >= 0) & (u <= slm_shape[1] - 1) & (v >= 0) & (v <= slm_shape[0] - 1)
    counts = {"skipped_frames": skipped, "outside_slm": int((~inside).sum())}
    counts.update({f"{a}_line_fit_rms_slm_px": round(f.rms, 4) for a, f in fits.items()})
    return SweepDecode(x[inside], y[inside], u[inside], v[inside], float(inside.mean()), counts)


def excluded_regions(
    u: NDArray, v: NDArray, regions: Sequence[Sequence[float]]
) -> NDArray[np.bool_]:
    """Whether SLM points (u, v) fall in any [row0, col0, row1, col1] rectangle.

    Parameters
    ----------
    u, v
        SLM column and row of the points.
    regions
        Rectangles ``[row0, col0, row1, col1]`` (SLM px; end exclusive), as the
        procedure's ``fit.exclude_regions_slm_px`` lists them.

    Returns
    -------
    ndarray
        Boolean, the shape of ``u``.

    Examples
    --------
    >>> excluded_regions(np.array([5.0, 50.0]), np.array([5.0, 5.0]), [[0, 0, 10, 10]]).tolist()
    [True, False]
    """
    out = np.zeros(np.shape(u), dtype=bool)
    for row0, col0, row1, col1 in regions:
        out |= (v >= row0) & (v < row1) & (u >= col0) & (u < col1)
    return out


def analyse_sweep(
    session: Session,
    proc: Mapping[str, Any],
    slm_shape: tuple[int, int],
    saturation: float,
    decoded: DecodedSweep | None = None,
) -> list[LaserDecode]:
    """Decode every laser of a sweep session and fit its smooth field map.

    Parameters
    ----------
    session
        A session of :func:`~sassi_bench.acquire.spectral_plans.sweep_plan`.
    proc
        The spectral-calibration procedure (``sweep.mode``, the fit's degree and
        excluded regions).
    slm_shape
        SLM (height, width).
    saturation
        Raw value at which the spectral camera saturates.
    decoded
        The lasers already decoded while the session was captured (the others are decoded
        from the session).

    Returns
    -------
    list of LaserDecode
        One per laser of the session, in order of wavelength.

    Raises
    ------
    ProcedureError
        When a laser's sweep decodes fewer than 1000 camera pixels.

    Examples
    --------
    Not run here (it needs captured sessions)::

        decoded = analyse_sweep(sweeps.sweep, proc, rig.slm.shape, 65535)
        [d.wavelength_nm for d in decoded]
        # [450.0, 520.0, 532.0, 635.0, 670.0]
    """
    degree = int(proc["fit"].get("field_degree", 5))
    out = []
    lasers = sorted(
        {float(s.tags["laser"]) for s in session.plan.steps if s.tags.get("role") == "full"}
    )
    for laser in lasers:
        pairs = decoded.decodes.get(laser) if decoded is not None else None
        if pairs is None:
            structured = proc["sweep"]["mode"] == "structured"
            decode = _structured_decode if structured else _line_decode
            pairs = decode(session, proc, laser, slm_shape, saturation)
        counts = pairs.counts
        if pairs.camera_x.size < 1000:
            raise ProcedureError(
                step_error(
                    f"sweep decoding at {laser:g} nm",
                    f"only {pairs.camera_x.size} camera pixels decoded ({counts})",
                    "check the exposure (saturated or too dark frames) and the laser",
                )
            )
        keep = ~excluded_regions(
            pairs.slm_u, pairs.slm_v, proc["fit"].get("exclude_regions_slm_px", [])
        )
        x, y, u, v = pairs.camera_x, pairs.camera_y, pairs.slm_u, pairs.slm_v
        if not keep.all():
            x, y, u, v = x[keep], y[keep], u[keep], v[keep]
        fx = fit_field(u, v, x, slm_shape, degree)
        fy = fit_field(u, v, y, slm_shape, degree)
        if "x_line_fit_rms_slm_px" in counts:
            # Line centres scatter in SLM px; convert with the local magnification.
            h, w = slm_shape
            scale = float(np.diff(fx(np.array([w / 2 - 1, w / 2 + 1]), h / 2))[0] / 2)
            slm_rms = np.hypot(counts["x_line_fit_rms_slm_px"], counts["y_line_fit_rms_slm_px"])
            residual = float(slm_rms * abs(scale))
        else:
            residual = float(np.hypot(fx.rms, fy.rms))
        laser_map = LaserMap(laser, fx, fy, x.size, counts)
        out.append(
            LaserDecode(laser, x, y, u, v, pairs.valid_fraction, counts, laser_map, residual)
        )
    return out


def pinhole_signal(session: Session, laser: float, saturation: float) -> PinholeSignal:
    """One laser's pinhole (blur) frames read from a sweep session: their mean minus the
    blank frame's, and the pixels any of them saturates.

    Examples
    --------
    Not run here (it needs captured sessions)::

        signal = pinhole_signal(sweeps.sweep, 532.0, 65535)
    """
    frames = _frames(session, session.plan.select(role="pinholes", laser=laser))
    return PinholeSignal(
        frames.mean(axis=0) - _one(session, role="blur-blank", laser=laser),
        (frames >= saturation).any(axis=0),
    )


def blur_form(procedure: Mapping[str, Any], desc: RigDescription) -> str:
    """The blur form a spectral calibration fits: the procedure's ``blur.form``, and for
    ``auto`` (the default) ``field_covariance`` on a rig described as an optical design
    (whose spots change over the field and by direction), else ``psf_quadratic``.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> blur_form({"blur": {}}, load_rig_description("sim"))
    'psf_quadratic'
    """
    form = str(procedure.get("blur", {}).get("form", "auto"))
    if form != "auto":
        return form
    return "field_covariance" if desc.design is not None else "psf_quadratic"


def blur_from_pinholes(
    session: Session,
    proc: Mapping[str, Any],
    dispersion: DispersionFit,
    slm_shape: tuple[int, int],
    saturation: float,
    pinholes: Mapping[float, PinholeSignal] | None = None,
    fill_factor: float | None = None,
    form: str = "psf_quadratic",
    laser_fwhm_nm: float = 0.0,
    lamp_spots: SpotMoments | None = None,
) -> BlurFit:
    """Fit the blur model to the spot widths of the sweep session's pinhole frames.

    The dispersion model places every pinhole's streak; the median spot width across
    the streaks gives one sigma per laser line, and the lines together the blur model.
    With the SLM's ``fill_factor`` the quadratic is the optics' PSF's, the SLM pixel's
    image (as the dispersion's field map draws it) added in quadrature, and the model the
    spot before the camera pixel (:func:`~sassi_bench.calibrate.blur.fit_blur`).

    Parameters
    ----------
    session
        A session of :func:`~sassi_bench.acquire.spectral_plans.sweep_plan`.
    proc
        The spectral-calibration procedure (``blur.window_sigmas``,
        ``blur.field_degree``); the pinholes are where the session's frames showed them.
    dispersion
        The fitted dispersion (and each line's fitted wavelength).
    slm_shape
        SLM (height, width).
    saturation
        Raw value at which the spectral camera saturates; saturated pixels are left out.
    pinholes
        Each laser's pinhole signal, averaged while the session was captured (the others
        are read from the session).
    fill_factor
        The SLM's fill factor (its pixels' open side over their pitch); None fits the
        paper's quadratic to the spot widths.
    form
        ``"psf_quadratic"`` (a round spot, the same over the field: the widths across
        the streaks, their median per line) or ``"field_covariance"`` (every pinhole's
        second moments, fitted over the field and the lines:
        :func:`~sassi_bench.calibrate.blur.fit_field_covariance`; needs ``fill_factor``).
    laser_fwhm_nm
        The lasers' line width: its dispersed image widens a spot along the streak, and
        is taken out of the moments along it (``field_covariance``).
    lamp_spots
        Spots of lamp lines past the lasers' band
        (:func:`~sassi_bench.reduce.lamps.lamp_field_spots`), fitted with the lasers'
        (``field_covariance``), so the field blur is measured where the bundle's bins
        reach instead of extrapolated there.

    Returns
    -------
    BlurFit

    Examples
    --------
    Not run here (it needs captured sessions)::

        blur = blur_from_pinholes(sweep, proc, dispersion, (400, 640), 65535)
    """
    plan = session.plan
    shown = [s for s in plan.steps if s.tags.get("role") == "pinholes"]
    lasers = sorted({float(s.tags["laser"]) for s in shown})
    # the pattern the frames showed (sessions record it; older ones spaced it by pitch)
    pattern_rows, pattern_cols = open_pixels(shown[0].pattern, slm_shape)
    sigmas = []
    moments: list[tuple[NDArray[np.float64], ...]] = []
    for laser in lasers:
        known = (pinholes or {}).get(laser)
        if known is None:
            known = pinhole_signal(session, laser, saturation)
        wavelength = dispersion.wavelengths_nm.get(laser, laser)
        x, y = dispersion.model.evaluate(pattern_cols.ravel(), pattern_rows.ravel(), wavelength)
        widths = measure_spot_widths(known.signal, x, y, 1.5, saturated=known.saturated)
        sigmas.append(widths.median_sigma_y)
        if form == "field_covariance":
            # the line's Gaussian profile, dispersed along the streak
            x_hi, _ = dispersion.model.evaluate(
                pattern_cols.ravel(), pattern_rows.ravel(), wavelength + 0.5
            )
            x_lo, _ = dispersion.model.evaluate(
                pattern_cols.ravel(), pattern_rows.ravel(), wavelength - 0.5
            )
            line_px2 = ((x_hi - x_lo) * laser_fwhm_nm / (2.0 * np.sqrt(2.0 * np.log(2.0)))) ** 2
            ok = widths.valid
            moments.append(
                (
                    pattern_cols.ravel()[ok].astype(np.float64),
                    pattern_rows.ravel()[ok].astype(np.float64),
                    np.full(int(ok.sum()), wavelength),
                    widths.sigma_x[ok] ** 2 - line_px2[ok],
                    widths.sigma_y[ok] ** 2,
                    widths.cov_xy[ok],
                )
            )
    wavelengths = [dispersion.wavelengths_nm.get(laser, laser) for laser in lasers]
    window = float(proc["blur"].get("window_sigmas", 3.0))
    if form == "field_covariance" and fill_factor is not None:
        aperture = slm_pixel_image_px(dispersion, slm_shape, fill_factor, wavelengths)
        if lamp_spots is not None:
            moments.append(
                (lamp_spots.u, lamp_spots.v, lamp_spots.wavelength_nm, lamp_spots.cxx,
                 lamp_spots.cyy, lamp_spots.cxy)
            )  # fmt: skip
        spots = SpotMoments(*(np.concatenate(parts) for parts in zip(*moments, strict=True)))
        degree = int(proc["blur"].get("field_degree", 4))
        return fit_field_covariance(spots, slm_shape, aperture**2 / 12.0, window, degree)
    if fill_factor is None:
        return fit_blur(wavelengths, sigmas, window)
    aperture = slm_pixel_image_px(dispersion, slm_shape, fill_factor, wavelengths)
    return fit_blur(wavelengths, sigmas, window, aperture_px=aperture)


def slm_pixel_image_px(
    dispersion: DispersionFit,
    slm_shape: tuple[int, int],
    fill_factor: float,
    wavelengths_nm: Sequence[float],
) -> float:
    """RMS side (camera px) of one SLM pixel's open area as the camera sees it across the
    dispersion: its box adds this squared over 12 to a spot's row variance.

    A uniform open square of side ``fill_factor`` SLM px, mapped by the dispersion's field
    map (local Jacobian ``dy/du``, ``dy/dv``), has the row variance
    ``fill_factor² (dy/du² + dy/dv²) / 12`` whatever its rotation. The Jacobian is the
    median over a grid of the field and the wavelengths given.

    Examples
    --------
    Not run here (it needs captured sessions)::

        slm_pixel_image_px(dispersion, (400, 640), 0.93, [450.0, 635.0])
        # 1.004
    """
    h, w = slm_shape
    v, u = np.mgrid[h / 8 : h : h / 4, w / 8 : w : w / 4]
    u, v = u.ravel(), v.ravel()
    slopes = []
    for lam in wavelengths_nm:
        _, y_u = dispersion.model.evaluate(np.r_[u - 0.5, u + 0.5], np.r_[v, v], lam)
        _, y_v = dispersion.model.evaluate(np.r_[u, u], np.r_[v - 0.5, v + 0.5], lam)
        n = u.size
        slopes.append((y_u[n:] - y_u[:n]) ** 2 + (y_v[n:] - y_v[:n]) ** 2)
    return float(fill_factor * np.sqrt(np.median(np.concatenate(slopes))))
