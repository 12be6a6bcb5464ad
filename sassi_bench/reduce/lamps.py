"""Lamp frames of the spectral calibration: capture, and the wavelength anchoring they give.

On a rig with ``wavelength_lamps`` the spectral calibration adds a short session
(``<id>-lamps``, :func:`capture_lamp_frames`): per lamp, closed-SLM frames and frames of a
sparse pinhole array (``lamps`` section of the procedure), exposed for the lamp. The
analysis (:func:`anchor_wavelengths`) cuts every pinhole's streak out of those frames
and fits the dispersion's column model and every laser's true wavelength to the laser
maps and the lamp lines together (:mod:`sassi_bench.calibrate.anchored`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.patterns import open_pixels
from sassi_bench.acquire.plan import Plan
from sassi_bench.acquire.saturation import clip_level
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import (
    BLUR_LINE_CLEAR_NM,
    LAMP_REACH_SIGMAS,
    blur_lamp_lines,
    lamp_band,
    lamp_pinholes,
)
from sassi_bench.bundle import BlurModel, DispersionModel
from sassi_bench.calibrate.anchored import (
    AnchoredWavelengths,
    LampStreaks,
    fit_anchored_wavelengths,
)
from sassi_bench.calibrate.anchored_form import anchored_form_error_px
from sassi_bench.calibrate.blur import SpotMoments
from sassi_bench.calibrate.dispersion import LaserMap, fit_dispersion
from sassi_bench.calibrate.lamp_streaks import (
    StreakProfiles,
    extract_streak_profiles,
    signal_and_variance,
)
from sassi_bench.calibrate.line_spots import measure_line_spots
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.optics.glass import Glass, get_glass
from sassi_bench.optics.lamps import LineList
from sassi_bench.reduce.lamp_budget import LampFrameRecord
from sassi_bench.reduce.sweep_stream import PinholeSignal
from sassi_bench.reduce.sweeps import blur_form, blur_from_pinholes
from sassi_bench.rig.config import RigDescription

__all__ = [
    "FORM_MISFIT_NM",
    "HELD_LABEL_NM",
    "LampAnchoring",
    "LampMeasurement",
    "anchor_wavelengths",
    "camera_noise",
    "captured_lamp_frames",
    "check_lamp_signal",
    "described_form_misfit_nm",
    "form_shift_nm",
    "lamp_field_spots",
    "lamp_frame_steps",
    "lamp_streaks",
]

#: The prior width (nm) that holds a confirmed laser line at its label.
HELD_LABEL_NM = 1e-3
#: Above this misfit of the column model's form to the described arm (nm RMS, half the
#: wavelength map's 0.1 nm goal) the lamps' laser measurements are checked for their
#: dependence on the form (:func:`form_shift_nm`). Where the form fits the arm, a line
#: that moves with one more power moves because the extra power is free where the lamp
#: lines blend, and the measurement at the model's order stands (the shipped rigs' misfits:
#: docs/notes/2026-11-29-achromat-wavelength-map.md).
FORM_MISFIT_NM = 0.05
#: A Gaussian's full width at half maximum over its sigma.
FWHM_PER_SIGMA = 2.0 * float(np.sqrt(2.0 * np.log(2.0)))


def camera_noise(desc: RigDescription) -> dict[str, float]:
    """The spectral camera's described noise: gain (e- per ADU), read noise, dark level.

    Examples
    --------
    >>> from sassi_bench.rig.config import load_rig_description
    >>> camera_noise(load_rig_description("sim"))["dark_adu"]
    100.0
    """
    cam = desc.spectral_camera
    return {
        "gain_e_per_adu": cam.full_well_e / (2**cam.bit_depth - 1 - cam.dark_offset_adu),
        "read_noise_e": cam.read_noise_e,
        "dark_adu": float(cam.dark_offset_adu),
    }


def lamp_frame_steps(plan: Plan, frames: int | None = None, **tags: Any) -> list[int]:
    """The steps of a lamp plan matching ``tags`` among every lamp's first ``frames``
    frames (None: all of them).

    Examples
    --------
    >>> from sassi_bench.acquire.spectral_plans import lamp_plan
    >>> plan = lamp_plan({}, {"lamp:HgAr": 0.05}, frames=3)
    >>> lamp_frame_steps(plan, 2), lamp_frame_steps(plan, 2, role="lamp-pinholes")
    ([0, 1, 3, 4], [3, 4])
    """
    chosen = plan.select(**tags)
    if frames is None:
        return chosen
    return [i for i in chosen if int(plan.steps[i].tags.get("frame", 0)) < frames]


def captured_lamp_frames(session: Session, role: str | None = None) -> int:
    """How many frames of every lamp the session holds: the largest ``n`` whose first
    ``n`` closed and pinhole frames of every lamp are all stored (``role="lamp-field"``:
    whose first ``n`` field frames at every offset are).

    Examples
    --------
    Not run here (it needs a captured session)::

        captured_lamp_frames(Session.open("lab-2026-11-22-lamps"))
        # 6
    """
    plan, done = session.plan, session.completed
    roles = ("lamp-blank", "lamp-pinholes") if role is None else (role,)
    chosen = [i for i, step in enumerate(plan.steps) if step.tags.get("role") in roles]
    planned = 1 + max((int(plan.steps[i].tags.get("frame", 0)) for i in chosen), default=-1)
    missing = [int(plan.steps[i].tags.get("frame", 0)) for i in chosen if i not in done]
    return min(missing, default=planned)


def lamp_streaks(
    session: Session,
    procedure: Mapping[str, Any],
    desc: RigDescription,
    model: DispersionModel,
    blur: BlurModel,
    frames: int | None = None,
) -> list[LampStreaks]:
    """Every lamp's pinhole streaks from a lamp session, ready for the anchored fit.

    Parameters
    ----------
    session
        A session of :func:`~sassi_bench.acquire.spectral_plans.lamp_plan`.
    procedure
        The spectral-calibration procedure.
    desc
        The rig's description (its lamps' line tables, relay scale, camera noise).
    model
        A dispersion model placing the streaks within a few pixels (lasers at labels).
    blur
        The measured spot width, for the lines' spot model.
    frames
        Use every lamp's first ``frames`` frames (None: every frame of the plan).

    Returns
    -------
    list of LampStreaks

    Raises
    ------
    ProcedureError
        When a lamp's pinhole frames show no light above its closed-SLM frames (the lamp
        was off), naming the lamp and the levels.

    Examples
    --------
    Not run here (it needs captured sessions)::

        lamps = lamp_streaks(sweeps.lamps, proc, desc, start.model, blur.model)
    """
    plan = session.plan
    tables = {lines.light: lines for lines in desc.lamp_lines().values()}
    pattern = plan.parameters.get("pinholes") or lamp_pinholes(procedure)
    slm_shape = (desc.slm.height, desc.slm.width)
    rows, cols = open_pixels(pattern, slm_shape)
    saturation = 2**desc.spectral_camera.bit_depth - 1
    aperture = desc.slm.fill_factor * desc.relay.scale
    row_pitch = int(pattern["pitch"][1]) * desc.relay.scale
    camera = camera_noise(desc)
    out = []
    for light in dict.fromkeys(step.tags["lamp"] for step in plan.steps):
        lines = tables.get(light)
        if lines is None:
            raise ProcedureError(
                step_error(
                    f"lamp frames {light}",
                    "the session's lamp is not one of the rig's wavelength_lamps "
                    f"({', '.join(tables) or 'none'})",
                    "analyse the session with the rig it was captured on",
                )
            )
        pinhole_frames = session.read_frames(
            lamp_frame_steps(plan, frames, role="lamp-pinholes", lamp=light)
        )
        blank = session.read_frames(lamp_frame_steps(plan, frames, role="lamp-blank", lamp=light))
        signal, variance = signal_and_variance(pinhole_frames, blank, **camera)
        band = lamp_band(lines, desc)
        half_rows = int(max(2, min(10, np.floor(row_pitch / 2.0) - 2)))

        def reach(lam, blur=blur):
            return LAMP_REACH_SIGMAS * blur.sigma(lam)

        profiles = extract_streak_profiles(
            signal,
            model,
            cols,
            rows,
            band,
            reach,
            light=light,
            half_rows=half_rows,
            variance=variance,
            invalid=(pinhole_frames >= clip_level(pinhole_frames, saturation)).any(axis=0),
        )
        check_lamp_signal(profiles)
        modelled = (lines.wavelengths_nm >= band[0]) & (lines.wavelengths_nm <= band[1])
        lam = lines.wavelengths_nm[modelled]
        out.append(
            LampStreaks(
                name=lines.name,
                lines_nm=lam,
                start_intensity=lines.relative_intensity[modelled],
                # The lamps' PSF starts at the blur's, at the field's centre.
                psf_sigma_px=blur.psf(
                    (desc.slm.width - 1) / 2.0,
                    (desc.slm.height - 1) / 2.0,
                    lam,
                    slm_pixel_variance_px2=aperture**2 / 12.0,
                ).along,
                spot=blur.profile,
                aperture_px=aperture,
                profiles=profiles,
            )
        )
    return out


def lamp_field_spots(
    session: Session,
    desc: RigDescription,
    model: DispersionModel,
    lasers_nm: Sequence[float],
    frames: int | None = None,
) -> SpotMoments | None:
    """The field blur's spots at the lamp lines past the lasers' band, from the lamp
    session's field frames (``role: lamp-field``, the pinhole grid at several offsets),
    the first ``frames`` at every offset (None: as many as the session holds).

    Each offset's frames, less the lamp's closed-SLM frames, give every pinhole's spot of
    every line of :func:`~sassi_bench.acquire.spectral_plans.blur_lamp_lines`, placed by
    ``model``; its weaker neighbours within
    :data:`~sassi_bench.acquire.spectral_plans.BLUR_LINE_CLEAR_NM` are fitted beside it
    (:func:`~sassi_bench.calibrate.line_spots.measure_line_spots`). Atomic lines are
    narrow: nothing of the line's own width is taken out.

    Returns
    -------
    SpotMoments or None
        None when the session has no field frames (planned without them, or a rig whose
        blur is round) or none taken.

    Examples
    --------
    Not run here (it needs a captured session)::

        spots = lamp_field_spots(sweeps.lamps, desc, dispersion.model, [450, 532, 670])
        np.unique(spots.wavelength_nm)
        # array([404.6565, 435.8335])
    """
    plan = session.plan
    field = plan.select(role="lamp-field")
    if frames is None:
        frames = captured_lamp_frames(session, role="lamp-field")
    if not field or frames < 1:
        return None
    tables = {lines.light: lines for lines in desc.lamp_lines().values()}
    slm_shape = (desc.slm.height, desc.slm.width)
    saturation = 2**desc.spectral_camera.bit_depth - 1
    parts = []
    for light in dict.fromkeys(plan.steps[i].tags["lamp"] for i in field):
        lines = tables[light]
        chosen = blur_lamp_lines(lines, lasers_nm, desc)
        taken = lamp_frame_steps(plan, None, role="lamp-blank", lamp=light)
        blank = session.read_frames([i for i in taken if i in session.completed])
        closed = blank.astype(np.float64).mean(axis=0)
        offsets = sorted({int(plan.steps[i].tags["offset"]) for i in field})
        for offset in offsets:
            steps = lamp_frame_steps(plan, frames, role="lamp-field", lamp=light, offset=offset)
            stack = session.read_frames(steps)
            signal = stack.astype(np.float64).mean(axis=0) - closed
            saturated = (stack >= clip_level(stack, saturation)).any(axis=0)
            rows, cols = open_pixels(plan.steps[steps[0]].pattern, slm_shape)
            u, v = cols.ravel().astype(np.float64), rows.ravel().astype(np.float64)
            for line in chosen:
                x, y = model.evaluate(u, v, line)
                near = lines.wavelengths_nm[
                    (np.abs(lines.wavelengths_nm - line) < BLUR_LINE_CLEAR_NM)
                    & (lines.wavelengths_nm != line)
                ]
                others = np.empty((u.size, 0))
                if near.size:
                    others = np.stack([model.evaluate(u, v, lam)[0] for lam in near], axis=1)
                spots = measure_line_spots(signal, x, y, others, 1.5, saturated)
                ok = spots.valid
                parts.append(
                    (u[ok], v[ok], np.full(int(ok.sum()), line), spots.cxx[ok], spots.cyy[ok],
                     spots.cxy[ok])
                )  # fmt: skip
    if not parts:
        return None
    return SpotMoments(*(np.concatenate(p) for p in zip(*parts, strict=True)))


def check_lamp_signal(profiles: StreakProfiles) -> None:
    """Refuse lamp frames without lamp light (the lamp off, or not on the diffuser): the
    brightest sample of most streaks must stand 10 noise sigmas above the closed frames.

    Raises
    ------
    ProcedureError
        Naming the lamp, the peak and the noise.

    Examples
    --------
    >>> z = np.zeros((3, 5))
    >>> off = StreakProfiles("lamp:HgAr", z[:, 0], z[:, 0], z, z, z + 25.0, np.zeros((3, 2), int))
    >>> check_lamp_signal(off)
    Traceback (most recent call last):
    ...
    sassi_bench.errors.ProcedureError: lamp frames lamp:HgAr: the pinhole frames show no lamp ...
    """
    finite = np.isfinite(profiles.variance)
    noise = float(np.sqrt(np.median(profiles.variance[finite])))
    peak = float(np.percentile(profiles.profile.max(axis=1), 90))
    if peak < 10.0 * noise:
        raise ProcedureError(
            step_error(
                f"lamp frames {profiles.light}",
                f"the pinhole frames show no lamp light above the closed-SLM frames (peak "
                f"{peak:.0f} ADU, noise {noise:.0f} ADU in a streak's row sum)",
                "switch the lamp on, let it warm up and check that it lights the diffuser, "
                "then capture the calibration again under a new --session",
            )
        )


@dataclass(frozen=True, eq=False)
class LampAnchoring:
    """What the lamp frames gave the spectral calibration.

    Attributes
    ----------
    fit
        The anchored fit: every laser's measured wavelength, the lamp lines' residuals.
    streaks
        The lamps' pinhole streaks it was fitted to.
    tables
        The lamps' line lists, by lamp name.
    exposures_s
        Exposure of each lamp's frames, by light name.
    frames
        Pinhole frames per lamp.
    measured
        The first fit, every laser's wavelength free: each line as the lamps measure it.
    confirmed
        Labels the lamps confirm (held at the label in ``fit``).
    unpinned
        Labels the lamps cannot pin: measured with a 1-sigma above the procedure's
        ``tolerances.laser_wavelength_sigma_nm``. A lamp only adds information: such a line
        keeps its label in ``fit`` (as without lamps), its lamp measurement recorded.
    record
        What the lamp step took and why (its batches and outcome), when it measured
        until confident.
    form_shift_nm
        Per label, how far the lamps' measurement moves when the column model gains a
        power (:func:`form_shift_nm`); added to the 1-sigma in quadrature when deciding
        which lines are confirmed or unpinned; measured only where the column model's
        form misses the described arm by more than :data:`FORM_MISFIT_NM`.
    form_misfit_nm
        That misfit (:func:`described_form_misfit_nm`).
    form_error_px
        How far ``fit``'s column misses the described optics with no noise, at 31
        wavelengths over 400-700 nm
        (:func:`~sassi_bench.calibrate.anchored_form.anchored_form_error_px`): the form's
        miss where the fit's weighting puts it, part of the map's stated uncertainty.
    """

    fit: AnchoredWavelengths
    streaks: list[LampStreaks]
    tables: dict[str, LineList]
    exposures_s: dict[str, float]
    frames: int
    measured: AnchoredWavelengths | None = None
    confirmed: tuple[float, ...] = ()
    unpinned: tuple[float, ...] = ()
    record: LampFrameRecord | None = None
    form_shift_nm: dict[float, float] = field(default_factory=dict)
    form_misfit_nm: float | None = None
    form_error_px: NDArray[np.float64] | None = None

    @property
    def line_sigma_by_label(self) -> dict[float, float]:
        """Label -> the 1-sigma of the wavelength each line is fitted at, for the map.

        A confirmed label is only known to agree with the lamps' measurement within that
        measurement's 1-sigma (its form shift added), not to the hold that fixes it in
        ``fit``: the measurement's 1-sigma is carried. The others carry ``fit``'s.
        """
        carried = self.fit.sigma_by_label
        if self.measured is not None:
            total = _total_sigma_nm(self.measured, self.form_shift_nm)
            for label, sigma in zip(self.measured.labels_nm, total, strict=True):
                if float(label) in self.confirmed:
                    carried[float(label)] = float(sigma)
        return carried

    def method(self, label: float) -> str:
        """How the fit took the line labelled ``label``: ``lamp-confirmed label``,
        ``label (lamps cannot pin it)`` or ``lamp-anchored``."""
        if float(label) in self.confirmed:
            return "lamp-confirmed label"
        if float(label) in self.unpinned:
            return "label (lamps cannot pin it)"
        return "lamp-anchored"

    def line_residuals_fwhm(self, blur: BlurModel) -> dict[str, dict[float, float]]:
        """Per lamp, per line bright enough to tell: its residual over the line's FWHM on
        the camera (2.355 spot sigmas of ``blur`` at the line, the widest over the field).

        As PypeIt judges a wavelength solution (``rms_thresh_frac_fwhm``): a fixed tolerance
        in nm is many times stricter where the dispersion is high than where it is low
        (at the red end of a 52 px N-BK7 streak a line's FWHM is about 72 nm, at the blue
        end of an N-SF11 streak about 7 nm).
        """
        out = {}
        for data in self.streaks:
            lamp = self.fit.lamps[data.name]
            residual = lamp.line_residual_nm
            told = np.isfinite(residual)
            lam = data.lines_nm[told]
            px = residual[told] * np.abs(lamp.dispersion_px_per_nm[told])
            fwhm = FWHM_PER_SIGMA * np.asarray(blur.sigma(lam), dtype=np.float64)
            out[data.name] = {float(x): float(r) for x, r in zip(lam, px / fwhm, strict=True)}
        return out

    def line_residuals_nm(self) -> dict[str, dict[float, tuple[float, float]]]:
        """Per lamp, per line bright enough to tell: its residual and its 1-sigma (nm)."""
        out = {}
        for data in self.streaks:
            lamp = self.fit.lamps[data.name]
            residual = lamp.line_residual_nm
            sigma = lamp.line_sigma_px / np.abs(lamp.dispersion_px_per_nm)
            told = np.isfinite(residual)
            out[data.name] = {
                float(lam): (float(r), float(s))
                for lam, r, s in zip(data.lines_nm[told], residual[told], sigma[told], strict=True)
            }
        return out


class LampMeasurement:
    """Every laser's wavelength as the lamps measure it from a lamp session's first frames,
    each line free within its label's tolerance.

    The sweep's part (a dispersion fit at the labels placing the streaks, and the blur
    from the sweep's pinhole frames) is fitted once, so the lamp step can measure after
    every batch of lamp frames (:mod:`sassi_bench.reduce.lamp_budget`).

    Parameters
    ----------
    sweep, procedure, desc, maps, field_degree, order, pinholes
        As for :func:`anchor_wavelengths`.

    Examples
    --------
    Not run here (it needs captured sessions)::

        measurement = LampMeasurement(sweep, proc, desc, maps)
        measurement.sigma_nm(lamps, frames=4)
        # {450.0: 0.04, 520.0: 0.05, 532.0: 0.05, 635.0: 0.19, 670.0: 0.42}
    """

    def __init__(
        self,
        sweep: Session,
        procedure: Mapping[str, Any],
        desc: RigDescription,
        maps: Sequence[LaserMap],
        *,
        field_degree: int = 5,
        order: int = 2,
        pinholes: Mapping[float, PinholeSignal] | None = None,
    ) -> None:
        self.procedure, self.desc, self.maps = procedure, desc, list(maps)
        self.slm_shape = (desc.slm.height, desc.slm.width)
        self.shape = {"field_degree": field_degree, "order": order}
        saturation = 2**desc.spectral_camera.bit_depth - 1
        self.start = fit_dispersion(maps, desc.prism.glass, self.slm_shape, **self.shape)
        self.blur = blur_from_pinholes(
            sweep, procedure, self.start, self.slm_shape, saturation, pinholes,
            desc.slm.fill_factor, form=blur_form(procedure, desc),
            laser_fwhm_nm=desc.light.laser_fwhm_nm,
        )  # fmt: skip
        self.tolerance = [desc.laser_tolerance(m.wavelength_nm) for m in maps]
        self.glass = get_glass(desc.prism.glass)
        # The last measurement, by session content and frames: the analysis after the
        # lamp step measures the same frames again.
        self._last_key: tuple[str, int] | None = None
        self._last: tuple[list[LampStreaks], AnchoredWavelengths] | None = None

    def fits(self, procedure: Mapping[str, Any], desc: RigDescription) -> bool:
        """Whether this measurement was set up with ``procedure`` on ``desc``."""
        return desc is self.desc and dict(procedure) == dict(self.procedure)

    def measure(self, lamps: Session, frames: int) -> tuple[list[LampStreaks], AnchoredWavelengths]:
        """The lamp streaks of every lamp's first ``frames`` frames and the fit with every
        laser's line free."""
        key = (lamps.sha256(), int(frames))
        if self._last is not None and self._last_key == key:
            return self._last
        streaks = lamp_streaks(
            lamps, self.procedure, self.desc, self.start.model, self.blur.model, frames
        )
        fit = fit_anchored_wavelengths(
            self.maps, streaks, self.glass, self.slm_shape, self.tolerance, **self.shape
        )
        self._last_key, self._last = key, (streaks, fit)
        return streaks, fit

    def sigma_nm(self, lamps: Session, frames: int) -> dict[float, float]:
        """Every laser's 1-sigma (nm), by label, from every lamp's first ``frames`` frames."""
        return self.measure(lamps, frames)[1].sigma_by_label


def anchor_wavelengths(
    sweep: Session,
    lamps: Session,
    procedure: Mapping[str, Any],
    desc: RigDescription,
    maps: Sequence[LaserMap],
    *,
    field_degree: int = 5,
    order: int = 2,
    pinholes: Mapping[float, PinholeSignal] | None = None,
    frames: int | None = None,
    record: LampFrameRecord | None = None,
    measurement: LampMeasurement | None = None,
) -> LampAnchoring:
    """Fit every laser's wavelength and the column model to the laser maps and lamp lines.

    The lasers' labels place the lamp streaks to within a few pixels (a dispersion fit
    at the labels, and its blur from the sweep's pinhole frames); the anchored fit then
    measures every laser's line with the lamp lines as absolute anchors, each laser's
    label a prior of the rig's ``laser_tolerance_nm``. A line the lamps cannot tell from
    its label (within ``fit.confirm_sigmas`` of the measurement's uncertainty and
    ``fit.confirm_max_nm``) is confirmed and held at its label, and the others are
    measured again: a label that holds is exact, a measurement is not. A line the lamps
    measure with a 1-sigma above ``tolerances.laser_wavelength_sigma_nm`` (its lamp lines
    blend at the rig's dispersion, or too few photons) keeps its label too: a lamp only
    adds information, and a measurement that uncertain would move the map further than
    the label is likely off (measured on the noisy N-BK7 bench, docs/rig_family.md). The
    ``laser_label`` check still compares the measurement with the label.

    Parameters
    ----------
    sweep, lamps
        The sweep session (its pinhole frames give the start's blur) and the lamp session.
    procedure
        The spectral-calibration procedure.
    desc
        The rig's description.
    maps
        Every laser's decoded map, labelled with its label.
    field_degree, order
        The dispersion model's shape.
    pinholes
        The sweep's pinhole signals, if averaged while it was captured.
    frames
        Use every lamp's first ``frames`` frames (None: as many as the session holds).
    record
        What the lamp step took and why, kept with the result.
    measurement
        The lamp step's measurement, reused when it was set up with ``procedure`` on
        ``desc`` (its last fit is not made again).

    Returns
    -------
    LampAnchoring

    Examples
    --------
    Not run here (it needs captured sessions)::

        anchoring = anchor_wavelengths(sweep, lamps, proc, desc, maps)
        anchoring.fit.by_label
        # {450.0: 454.97, 520.0: 516.17, 532.0: 531.98, 635.0: 639.2, 670.0: 665.14}
    """
    if measurement is None or not measurement.fits(procedure, desc):
        measurement = LampMeasurement(
            sweep, procedure, desc, maps, field_degree=field_degree, order=order,
            pinholes=pinholes,
        )  # fmt: skip
    if frames is None:
        frames = captured_lamp_frames(lamps)
    streaks, measured = measurement.measure(lamps, frames)
    maps, tolerance = measurement.maps, measurement.tolerance
    glass, slm_shape, shape = measurement.glass, measurement.slm_shape, measurement.shape
    misfit = described_form_misfit_nm(desc, int(shape["order"]))
    form_shift = (
        form_shift_nm(measured, maps, streaks, glass, slm_shape, tolerance, shape)
        if misfit > FORM_MISFIT_NM
        else {}
    )
    confirmed = _confirmed_labels(measured, procedure, form_shift)
    unpinned = _unpinned_labels(measured, procedure, form_shift) - confirmed
    fit = measured
    held = list(tolerance)
    if confirmed or unpinned:
        # A label the lamps cannot tell from the measurement is exact to better than the
        # measurement, and one they cannot pin is no worse than it: those lines are held
        # at their labels, the others measured again.
        held = [HELD_LABEL_NM if m.wavelength_nm in confirmed | unpinned else t
                for m, t in zip(maps, tolerance, strict=True)]  # fmt: skip
        fit = fit_anchored_wavelengths(maps, streaks, glass, slm_shape, held, **shape)
    relay = desc.nominal_relay()
    form_error = anchored_form_error_px(
        fit, streaks, glass, slm_shape, held, lambda u, v, lam: relay.forward(u, v, lam)[0],
        **shape,
    )  # fmt: skip
    exposures = {k: float(v) for k, v in lamps.plan.parameters.get("exposures_s", {}).items()}
    return LampAnchoring(
        fit=fit,
        streaks=streaks,
        tables=desc.lamp_lines(),
        exposures_s=exposures,
        frames=frames,
        measured=measured,
        confirmed=tuple(sorted(confirmed)),
        unpinned=tuple(sorted(unpinned)),
        record=record,
        form_shift_nm=form_shift,
        form_misfit_nm=misfit,
        form_error_px=form_error,
    )


def described_form_misfit_nm(desc: RigDescription, order: int) -> float:
    """How far the column model's form (a polynomial of ``order`` in the glass index at
    each field point) misses the described arm: RMS over the field and 400-700 nm, in nm.

    Read from the rig's described optics (``nominal_relay``), never the bench as built.

    Examples
    --------
    Not run here (it ray-traces the described optics)::

        described_form_misfit_nm(load_rig_description("sim-achromat"), 2)
        # 0.0852
    """
    relay = desc.nominal_relay()
    glass = get_glass(desc.prism.glass)
    h, w = desc.slm.height, desc.slm.width
    u, v = np.meshgrid(np.linspace(0, w - 1, 17), np.linspace(0, h - 1, 11))
    lam = np.linspace(400.0, 700.0, 31)
    x, _ = relay.forward(u.ravel()[:, None], v.ravel()[:, None], lam[None, :])
    index = glass.index(lam)
    spectral = (index - glass.index(550.0)) / (index[0] - index[-1])
    powers = spectral[:, None] ** np.arange(order + 1)[None, :]
    coeffs, *_ = np.linalg.lstsq(powers, x.T, rcond=None)
    error_nm = ((powers @ coeffs).T - x) / np.gradient(x, lam, axis=1)
    return float(np.sqrt(np.mean(error_nm**2)))


def form_shift_nm(
    measured: AnchoredWavelengths,
    maps: Sequence[LaserMap],
    streaks: Sequence[LampStreaks],
    glass: Glass,
    slm_shape: tuple[int, int],
    tolerance: Sequence[float],
    shape: Mapping[str, int],
) -> dict[float, float]:
    """How far each laser's lamp measurement moves when the column model gains a power.

    Where the lamp lines near a laser blend (a spot many lines wide at the red end of a
    low-dispersion arm), their free amplitudes trade against the positions and the
    model's form decides where the laser's line is measured, by far more than its stated
    1-sigma (docs/notes/2026-11-29-achromat-wavelength-map.md). The move is part of the
    measurement's uncertainty. It costs one more anchored fit (seconds, no frames).

    Returns
    -------
    dict
        Label -> measured wavelength at ``order + 1`` minus at ``order`` (nm).
    """
    richer = fit_anchored_wavelengths(
        maps, streaks, glass, slm_shape, tolerance,
        field_degree=int(shape["field_degree"]), order=int(shape["order"]) + 1,
    )  # fmt: skip
    return {
        float(label): float(high - low)
        for label, high, low in zip(
            measured.labels_nm, richer.wavelengths_nm, measured.wavelengths_nm, strict=True
        )
    }


def _total_sigma_nm(
    measured: AnchoredWavelengths, form_shift: Mapping[float, float]
) -> NDArray[np.float64]:
    """Each laser's 1-sigma with its form shift added in quadrature."""
    shift = np.array([form_shift.get(float(label), 0.0) for label in measured.labels_nm])
    return np.hypot(measured.sigma_nm, shift)


def _unpinned_labels(
    measured: AnchoredWavelengths,
    procedure: Mapping[str, Any],
    form_shift: Mapping[float, float] | None = None,
) -> set[float]:
    """Labels the lamps measure with a 1-sigma (its form shift added) above
    ``tolerances.laser_wavelength_sigma_nm``."""
    tolerance = float((procedure.get("tolerances") or {}).get("laser_wavelength_sigma_nm", 0.5))
    sigma = _total_sigma_nm(measured, form_shift or {})
    return {float(label) for label in measured.labels_nm[sigma > tolerance]}


def _confirmed_labels(
    measured: AnchoredWavelengths,
    procedure: Mapping[str, Any],
    form_shift: Mapping[float, float] | None = None,
) -> set[float]:
    """Labels the lamps confirm: the freely measured line within ``fit.confirm_sigmas``
    of its 1-sigma uncertainty (its form shift added) and within ``fit.confirm_max_nm``
    of its label."""
    fit = procedure.get("fit") or {}
    sigmas = float(fit.get("confirm_sigmas", 3.0))
    largest = float(fit.get("confirm_max_nm", 0.3))
    off = np.abs(measured.wavelengths_nm - measured.labels_nm)
    keep = (off <= sigmas * _total_sigma_nm(measured, form_shift or {})) & (off <= largest)
    return {float(label) for label in measured.labels_nm[keep]}
