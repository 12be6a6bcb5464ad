"""The analysis stage of the spectral calibration: sweeps -> dispersion, blur, checks.

:func:`analyse_spectral_sweeps` decodes the captured sweeps
(:mod:`sassi_bench.reduce.sweeps`), checks the laser lines against each
other, fits the joint dispersion model and the blur, and grades the result against the
procedure's tolerances (:func:`grade`). With lamp frames (a rig with wavelength lamps)
the lamp lines anchor the wavelength axis and every laser's line is measured
(:mod:`sassi_bench.reduce.lamps`) instead of checked against the others. Without
lamps, a line the rig states to a test sheet's accuracy is fitted where the maps and the
sheet together put it (:mod:`sassi_bench.calibrate.stated_lines`).
Fit settings and tolerances may differ from those the sweeps were captured with (a
region excluded in the notebook).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from sassi_bench.acquire.plan_geometry import planned_spectral
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationModels, QualityCheck
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.calibrate.blur import BlurFit
from sassi_bench.calibrate.dispersion import (
    DispersionFit,
    LaserLine,
    check_laser_lines,
    fit_dispersion,
)
from sassi_bench.calibrate.grey_response import GreyResponse
from sassi_bench.calibrate.stated_lines import StatedLine, estimate_stated_lines
from sassi_bench.reduce.blur_budget import BlurFrameRecord, LampFieldFrameRecord
from sassi_bench.reduce.blur_frames import pinhole_signals
from sassi_bench.reduce.bundle_checks import (
    bundle_check_notes,
    line_uncertainty_notes,
    measured_bundle_checks,
    off_label_notes,
)
from sassi_bench.reduce.design_comparison import DesignComparison, comparison_of_models
from sassi_bench.reduce.lamp_budget import LampFrameRecord
from sassi_bench.reduce.lamps import (
    LampAnchoring,
    LampMeasurement,
    anchor_wavelengths,
    lamp_field_spots,
)
from sassi_bench.reduce.sweep_stream import DecodedSweep
from sassi_bench.reduce.sweeps import (
    LaserDecode,
    analyse_sweep,
    blur_form,
    blur_from_pinholes,
    measure_response,
)

__all__ = [
    "SpectralCalibration",
    "SpectralSweeps",
    "analyse_spectral_sweeps",
    "blur_band_notes",
    "blur_notes",
    "grade",
    "lamp_measurement",
    "laser_line_checks",
    "laser_line_notes",
    "placed_line_note",
    "spectral_notes",
    "stated_line_sigma_nm",
]


@dataclass(frozen=True)
class SpectralSweeps:
    """The raw sessions of a spectral calibration: the grey-level response (structured
    sweeps only), the laser sweep itself and the lamp frames (rigs with lamps only); and
    what was measured from them as they were captured: the grey-level response, the
    sweep's decode (None: the analysis reads them from the sessions), what the lamp step
    took and why, and its measurement (reused by the analysis with the same procedure);
    the blur step's added pinhole frames (None: the sweep's were enough, or the blur
    form states no uncertainty) and what it took and why; and what the lamp field step
    took and why (a field blur with lamp lines past the lasers' band)."""

    grey: Session | None
    sweep: Session
    lamps: Session | None = None
    grey_response: GreyResponse | None = None
    decoded: DecodedSweep | None = None
    lamp_record: LampFrameRecord | None = None
    lamp_measurement: LampMeasurement | None = None
    blur: Session | None = None
    blur_record: BlurFrameRecord | None = None
    lamp_field_record: LampFieldFrameRecord | None = None

    @property
    def sessions(self) -> list[Session]:
        """The sessions, in capture order."""
        return [s for s in (self.grey, self.sweep, self.blur, self.lamps) if s is not None]


@dataclass
class SpectralCalibration:
    """Everything the spectral calibration produced."""

    procedure: dict[str, Any]
    rig_description: Any
    lasers: list[LaserDecode]
    dispersion: DispersionFit
    blur: BlurFit
    grey_response: GreyResponse | None
    checks: list[QualityCheck]
    sessions: list[Session]
    bundle_path: Path | None = None
    figures: dict[str, bytes] = field(default_factory=dict)
    laser_lines: dict[float, LaserLine] = field(default_factory=dict)
    anchoring: LampAnchoring | None = None
    #: On a design rig, the measured maps against the described design.
    design_comparison: DesignComparison | None = None
    blur_record: BlurFrameRecord | None = None
    lamp_field_record: LampFieldFrameRecord | None = None
    #: Without lamps, the lines stated to a test sheet's accuracy as the maps place them.
    stated_lines: dict[float, StatedLine] = field(default_factory=dict)

    @property
    def passed(self) -> bool:
        """Whether every quality check passed."""
        return all(c.passed for c in self.checks)

    def models(self) -> CalibrationModels:
        """The bundle models of this calibration.

        Returns
        -------
        CalibrationModels
            The fitted dispersion, its wavelength bins and the blur model.

        Examples
        --------
        Not run here (it needs captured sessions)::

            result.models().bins.count
            # 68
        """
        return CalibrationModels(
            dispersion=self.dispersion.model, bins=self.dispersion.bins, blur=self.blur.model
        )


def grade(
    result_lasers: Sequence[LaserDecode],
    dispersion: DispersionFit,
    blur: BlurFit,
    tolerances: Mapping[str, float],
    laser_lines: Mapping[float, LaserLine] | None = None,
    anchoring: LampAnchoring | None = None,
    laser_tolerance_nm: Mapping[float, float] | None = None,
) -> list[QualityCheck]:
    """Quality checks of a spectral calibration against the procedure's tolerances.

    Parameters
    ----------
    result_lasers
        Every laser's decode: its correspondence RMS and valid fraction are checked.
    dispersion
        The dispersion fit: its leave-one-out errors are checked.
    blur
        The blur fit: its RMS is checked.
    tolerances
        The procedure's ``tolerances`` section.
    laser_lines
        From :func:`~sassi_bench.calibrate.dispersion.check_laser_lines`: adds one check
        per line fitted at its label, ``laser_line_<label>nm``, how far the other lines
        put it from its label, against ``laser_line_nm`` and, in quadrature, how far the
        others' stated accuracy moves their estimate (wide for an end line, whose
        estimate is an extrapolation). A line fitted at its estimate has no such check
        (it agrees with the others by construction); the bundle records its estimate.
    anchoring
        The lamp anchoring, if any: adds ``lamp_line_rms_fwhm`` (the lamp lines'
        residuals at the fitted model, each over its line's FWHM), and per laser
        ``laser_label_<label>nm`` (how far the lamps measure it from its label, against
        ``laser_tolerance_nm`` plus three times that uncertainty).
    laser_tolerance_nm
        Per label, how far the rig allows a line to be off its label.

    The checks that measure the bundle follow
    (:func:`~sassi_bench.reduce.bundle_checks.measured_bundle_checks`): the map's stated
    1-sigma (``map_sigma_px``, ``map_sigma_nm``) and, with lamps, the lamp line furthest
    from the map in its own sigmas (``lamp_line_max_sigmas``).

    Returns
    -------
    list of QualityCheck

    Examples
    --------
    Not run here (it needs captured sessions)::

        checks = grade(result.lasers, result.dispersion, result.blur, tolerances)
        all(check.passed for check in checks)
        # True
    """
    checks = []
    for laser in result_lasers:
        name = f"{laser.wavelength_nm:g}nm"
        checks.append(
            QualityCheck.at_most(
                f"correspondence_rms_{name}",
                laser.residual_rms_px,
                tolerances["correspondence_rms_px"],
                "px",
            )
        )
        checks.append(
            QualityCheck.at_least(
                f"valid_fraction_{name}",
                laser.valid_fraction,
                tolerances["valid_fraction_min"],
                "1",
            )
        )
    checks += laser_line_checks(
        laser_lines or {}, tolerances.get("laser_line_nm", 0.5), dispersion.estimated_lines
    )
    if dispersion.leave_one_out:
        checks.append(
            QualityCheck.at_most(
                "leave_one_out_rms_nm",
                dispersion.leave_one_out_rms_nm,
                tolerances["leave_one_out_rms_nm"],
                "nm",
            )
        )
        checks.append(
            QualityCheck.at_most(
                "leave_one_out_max_px",
                dispersion.leave_one_out_max_px,
                tolerances["leave_one_out_max_px"],
                "px",
            )
        )
    checks.append(
        QualityCheck.at_most("blur_fit_rms_px", blur.rms_px, tolerances["blur_fit_rms_px"], "px")
    )
    if anchoring is not None:
        checks += _anchoring_checks(anchoring, blur, tolerances, laser_tolerance_nm or {})
    return checks + measured_bundle_checks(dispersion, anchoring, tolerances)


def laser_line_checks(
    laser_lines: Mapping[float, LaserLine],
    tolerance_nm: float,
    estimated: Sequence[float] = (),
) -> list[QualityCheck]:
    """One ``laser_line_<label>nm`` check per line fitted at its label: how far the other
    lines put it from its label, against what a right bundle allows there
    (:meth:`~sassi_bench.calibrate.dispersion.LaserLine.allowed_nm`: ``tolerance_nm`` and,
    in quadrature, how far the others' stated accuracy moves their estimate).

    Parameters
    ----------
    laser_lines
        From :func:`~sassi_bench.calibrate.dispersion.check_laser_lines`.
    tolerance_nm
        The procedure's ``tolerances.laser_line_nm``.
    estimated
        Labels fitted at their estimate: no check (they agree with the others by
        construction).

    Returns
    -------
    list of QualityCheck

    Examples
    --------
    >>> from sassi_bench.calibrate.dispersion import LaserLine
    >>> lines = {405.0: LaserLine(405.0, 401.3, (516.0, 532.0, 637.0), False, 8.1),
    ...          516.0: LaserLine(516.0, 516.2, (405.0, 532.0, 637.0), False, 0.5)}
    >>> [c.describe() for c in laser_line_checks(lines, 0.5)]  # doctest: +NORMALIZE_WHITESPACE
    ['laser_line_405nm = 3.7 nm (tolerance <= 8.12 nm)',
     'laser_line_516nm = 0.2 nm (tolerance <= 0.707 nm)']
    """
    skip = set(estimated)
    return [
        QualityCheck.at_most(
            f"laser_line_{label:g}nm", abs(line.offset_nm), line.allowed_nm(tolerance_nm), "nm"
        )
        for label, line in laser_lines.items()
        if label not in skip and np.isfinite(line.estimated_nm)
    ]


def _anchoring_checks(
    anchoring: LampAnchoring,
    blur: BlurFit,
    tolerances: Mapping[str, float],
    laser_tolerance: Mapping,
) -> list[QualityCheck]:
    # The lamp lines against their own width: a wrong glass, line list or relay leaves
    # residuals of a sizeable fraction of a FWHM; photon noise leaves a few per cent.
    ratios = [
        r for lines in anchoring.line_residuals_fwhm(blur.model).values() for r in lines.values()
    ]
    rms = float(np.sqrt(np.mean(np.square(ratios)))) if ratios else float("nan")
    checks = [
        QualityCheck.at_most(
            "lamp_line_rms_fwhm", rms, tolerances.get("lamp_line_rms_fwhm", 0.15), "1"
        ),
    ]
    # A line the lamps cannot pin keeps its label (``LampAnchoring.unpinned``): its
    # uncertainty is not a fault of the bundle, so it is recorded and noted, not graded.
    fit = anchoring.measured or anchoring.fit  # each line as the lamps measure it
    for label, measured, sigma in zip(fit.labels_nm, fit.wavelengths_nm, fit.sigma_nm, strict=True):
        # Off its label by more than the rig allows, beyond the measurement's own 3 sigma.
        checks.append(
            QualityCheck.at_most(
                f"laser_label_{label:g}nm",
                abs(float(measured - label)),
                float(laser_tolerance.get(float(label), 5.0)) + 3.0 * float(sigma),
                "nm",
            )
        )
    return checks


#: The capture settings a procedure may leave null (derived from the rig's optics).
_DERIVED_SETTINGS = (
    ("sweep", "phase_period_px"),
    ("sweep", "gray_block_px"),
    ("blur", "pinhole_pitch_px"),
    ("lamps", "pinhole_pitch_px"),
    ("fit", "field_degree"),
    ("fit", "dispersion_order"),
)


def _capture_settings(
    procedure: Mapping[str, Any], sweeps: SpectralSweeps, desc: Any
) -> dict[str, Any]:
    """The procedure with every capture setting it leaves null as the sweeps were captured
    with (the sweep session's plan records its procedure), else derived for the rig."""
    proc = copy.deepcopy(dict(procedure))
    captured = thaw(sweeps.sweep.plan.parameters.get("procedure") or {})
    for section, key in _DERIVED_SETTINGS:
        given = (proc.get(section) or {}).get(key)
        recorded = (captured.get(section) or {}).get(key)
        if given is None and recorded is not None:
            proc[section] = {**(proc.get(section) or {}), key: recorded}
    return planned_spectral(proc, desc)


def lamp_measurement(
    sweeps: SpectralSweeps, procedure: Mapping[str, Any], rig_description: Any
) -> LampMeasurement:
    """What the lamp frames measure, set up from the sweep (its laser maps, blur), for
    the lamp step to measure after every batch of lamp frames.

    Parameters
    ----------
    sweeps
        The sessions so far (the sweep captured; the lamp session need not be).
    procedure, rig_description
        As for :func:`analyse_spectral_sweeps`.

    Returns
    -------
    LampMeasurement

    Examples
    --------
    Not run here (it needs captured sessions)::

        lamp_measurement(sweeps, proc, rig.description).sigma_nm(lamps_session, 4)
        # {450.0: 0.04, 520.0: 0.05, 532.0: 0.05, 635.0: 0.19, 670.0: 0.42}
    """
    desc = rig_description
    proc = _capture_settings(procedure, sweeps, desc)
    saturation = 2**desc.spectral_camera.bit_depth - 1
    slm_shape = (desc.slm.height, desc.slm.width)
    decoded = analyse_sweep(sweeps.sweep, proc, slm_shape, saturation, sweeps.decoded)
    return LampMeasurement(
        sweeps.sweep, proc, desc, [d.laser_map for d in decoded],
        field_degree=int(proc["fit"].get("field_degree", 5)),
        order=int(proc["fit"].get("dispersion_order", 2)),
        pinholes=pinhole_signals(
            sweeps.sweep, saturation, sweeps.decoded.pinholes if sweeps.decoded else None,
            sweeps.blur,
        ),
    )  # fmt: skip


def analyse_spectral_sweeps(
    sweeps: SpectralSweeps, procedure: Mapping[str, Any], rig_description: Any
) -> SpectralCalibration:
    """Decode the sweeps, fit the dispersion and blur models and grade them.

    Parameters
    ----------
    sweeps
        From :func:`~sassi_bench.workflows.spectral.capture_spectral_sweeps`.
    procedure
        The procedure the sweeps were captured with (fit settings and tolerances).
    rig_description
        The rig's description (SLM shape, camera bit depth, prism glass).

    Returns
    -------
    SpectralCalibration

    Examples
    --------
    Not run here (it needs captured sessions)::

        result = analyse_spectral_sweeps(sweeps, proc, rig.description)
        result.passed
        # True
    """
    desc = rig_description
    proc = _capture_settings(procedure, sweeps, desc)
    slm_shape = (desc.slm.height, desc.slm.width)
    saturation = 2**desc.spectral_camera.bit_depth - 1
    response = sweeps.grey_response
    if response is None and sweeps.grey is not None:
        response = measure_response(sweeps.grey, saturation)
    decoded = analyse_sweep(sweeps.sweep, proc, slm_shape, saturation, sweeps.decoded)
    pinholes = pinhole_signals(
        sweeps.sweep, saturation, sweeps.decoded.pinholes if sweeps.decoded else None, sweeps.blur
    )
    maps = [d.laser_map for d in decoded]
    shape = {
        "field_degree": int(proc["fit"].get("field_degree", 5)),
        "order": int(proc["fit"].get("dispersion_order", 2)),
    }
    if sweeps.lamps is not None:
        anchoring = anchor_wavelengths(
            sweeps.sweep, sweeps.lamps, proc, desc, maps, pinholes=pinholes,
            record=sweeps.lamp_record, measurement=sweeps.lamp_measurement, **shape,
        )  # fmt: skip
        dispersion = fit_dispersion(
            maps,
            desc.prism.glass,
            slm_shape,
            wavelengths_nm=anchoring.fit.by_label,
            x_information=anchoring.fit.information,
            wavelength_sigma_nm=anchoring.line_sigma_by_label,
            form_error_px=anchoring.form_error_px,
            **shape,
        )
        form = blur_form(proc, desc)
        lamp_spots = None
        if form == "field_covariance":
            lasers = [m.wavelength_nm for m in maps]
            lamp_spots = lamp_field_spots(sweeps.lamps, desc, dispersion.model, lasers)
        blur = blur_from_pinholes(
            sweeps.sweep, proc, dispersion, slm_shape, saturation, pinholes, desc.slm.fill_factor,
            form=form, laser_fwhm_nm=desc.light.laser_fwhm_nm, lamp_spots=lamp_spots,
        )  # fmt: skip
        tolerance = {m.wavelength_nm: desc.laser_tolerance(m.wavelength_nm) for m in maps}
        checks = grade(decoded, dispersion, blur, proc["tolerances"], None, anchoring, tolerance)
        return _compared_with_design(SpectralCalibration(
            proc, desc, decoded, dispersion, blur, response, checks, sweeps.sessions,
            anchoring=anchoring, blur_record=sweeps.blur_record,
            lamp_field_record=sweeps.lamp_field_record,
        ))  # fmt: skip
    lines = check_laser_lines(
        maps,
        desc.prism.glass_model(),
        slm_shape,
        float(proc["tolerances"].get("laser_line_nm", 0.5)),
        accuracy_nm={m.wavelength_nm: desc.laser_tolerance(m.wavelength_nm) for m in maps},
        **shape,
    )
    estimate = bool(proc["fit"].get("estimate_laser_wavelengths", False))
    stated = stated_line_sigma_nm(desc, [m.wavelength_nm for m in maps])
    placed = {k: v for k, v in stated.items() if not lines[k].off_label}
    sheets = {}
    if placed:
        relay = desc.nominal_relay()
        sheets = estimate_stated_lines(
            maps,
            desc.prism.glass_model(),
            slm_shape,
            placed,
            lambda u, v, lam: relay.forward(u, v, lam)[0],
            **shape,
        )
    fitted = {k: v.estimated_nm for k, v in sheets.items()}
    if estimate:
        fitted.update({k: v.estimated_nm for k, v in lines.items() if v.off_label})
    dispersion = fit_dispersion(
        maps,
        desc.prism.glass_model(),
        slm_shape,
        wavelengths_nm=fitted or None,
        wavelength_sigma_nm={**stated, **{k: v.sigma_nm for k, v in sheets.items()}},
        wavelength_correlation={
            (k, other): rho for k, v in sheets.items() for other, rho in v.correlation.items()
        },
        **shape,
    )
    blur = blur_from_pinholes(
        sweeps.sweep, proc, dispersion, slm_shape, saturation, pinholes, desc.slm.fill_factor,
        form=blur_form(proc, desc), laser_fwhm_nm=desc.light.laser_fwhm_nm,
    )  # fmt: skip
    checks = grade(decoded, dispersion, blur, proc["tolerances"], lines)
    return _compared_with_design(
        SpectralCalibration(
            proc,
            desc,
            decoded,
            dispersion,
            blur,
            response,
            checks,
            sweeps.sessions,
            laser_lines=lines,
            blur_record=sweeps.blur_record,
            stated_lines=sheets,
        )
    )


def stated_line_sigma_nm(desc: Any, labels: Sequence[float]) -> dict[float, float]:
    """The 1-sigma of each laser line a rig without lamps states (its
    ``laser_tolerance_nm``, read as the prior's sigma as the lamp-anchored fit reads it):
    a test sheet's accuracy. A line the rig states nothing for is taken at its label;
    the other lines check it (``laser_line_<label>nm``). The fit places a stated line
    from the maps and its sheet together
    (:func:`~sassi_bench.calibrate.stated_lines.estimate_stated_lines`).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> rig = SimpleNamespace(laser_tolerance_nm={441.93: 0.28})
    >>> stated_line_sigma_nm(rig, [441.93, 488.0])
    {441.93: 0.28}
    >>> stated_line_sigma_nm(SimpleNamespace(laser_tolerance_nm=None), [488.0])
    {}
    """
    given = desc.laser_tolerance_nm
    if given is None:
        return {}
    if isinstance(given, Mapping):
        stated = {float(k): float(v) for k, v in given.items()}
        return {float(x): stated[float(x)] for x in labels if float(x) in stated}
    return {float(x): float(given) for x in labels}


def _compared_with_design(result: SpectralCalibration) -> SpectralCalibration:
    """On a rig described as an optical design, its measured maps against the design as
    described (:mod:`sassi_bench.reduce.design_comparison`), over the lasers' band."""
    desc = result.rig_description
    if getattr(desc, "design", None) is None:
        return result
    lines = np.asarray(result.blur.wavelengths_nm, dtype=np.float64)
    result.design_comparison = comparison_of_models(
        desc.design,
        result.models(),
        (desc.slm.height, desc.slm.width),
        (desc.spectral_camera.height, desc.spectral_camera.width),
        (float(lines.min()), float(lines.max())),
    )
    return result


#: A blur fit whose own error between the lasers (``relative_error``) exceeds this gets
#: a note. The default benches' fits state 0.6 %; a blur curve no quadratic follows
#: (``tests/rigs/prism-sf10.yaml``, 8 % off between its lasers) states 11.5 %.
BLUR_NOTE_ERROR = 0.05


def spectral_notes(result: SpectralCalibration) -> list[str]:
    """Every note of a spectral calibration: its laser lines', then its blur's.

    Examples
    --------
    Not run here (it needs captured sessions)::

        spectral_notes(result)
        # ['laser 450 nm: measured 450.00 +- 0.01 nm against the HgAr, Ne lamp lines ...']
    """
    design = getattr(result, "design_comparison", None)
    records = (result.blur_record, getattr(result, "lamp_field_record", None))
    frames = [record.note() for record in records if record is not None]
    prism = getattr(result.rig_description, "prism", None)
    glass = str(getattr(prism, "glass", "as described"))
    return (
        laser_line_notes(result)
        + bundle_check_notes(result.checks, result.dispersion, result.anchoring, glass)
        + off_label_notes(result.checks, result.anchoring, glass)
        + line_uncertainty_notes(result.dispersion)
        + blur_notes(result.blur)
        + blur_band_notes(result.blur, result.dispersion.bins.edges_nm)
        + frames
        + ([f"as designed against as built: {design.verdict}"] if design is not None else [])
    )


def blur_notes(blur: BlurFit) -> list[str]:
    """A note when the blur curve is uncertain between the lasers, naming where a line
    would pin it.

    Parameters
    ----------
    blur
        The blur fit (its model's ``relative_error`` and the lines it was fitted at).

    Returns
    -------
    list of str
        One note when the fit's own error exceeds :data:`BLUR_NOTE_ERROR`, else none.

    Examples
    --------
    >>> from sassi_bench.calibrate.blur import fit_blur
    >>> fit = fit_blur([450, 520, 532, 635, 670], [1.0, 0.6, 0.6, 1.3, 1.7])
    >>> print(blur_notes(fit)[0])  # doctest: +ELLIPSIS +NORMALIZE_WHITESPACE
    blur: each laser's spot width, predicted by the fit to the others, is off by 17.2 % RMS
    (above 5 %), ... a line in the widest gap, 532-635 nm, would pin it
    """
    error = blur.model.relative_error
    if error is None or error <= BLUR_NOTE_ERROR:
        return []
    lines = np.sort(np.asarray(blur.wavelengths_nm, dtype=np.float64))
    widest = int(np.argmax(np.diff(lines)))
    return [
        f"blur: each laser's spot width, predicted by the fit to the others, is off by "
        f"{100 * error:.1f} % RMS (above {100 * BLUR_NOTE_ERROR:.0f} %), so the blur curve "
        "between the lasers is uncertain (the scan's deblur allows for it); a line in "
        f"the widest gap, {lines[widest]:.0f}-{lines[widest + 1]:.0f} nm, would pin it"
    ]


def blur_band_notes(blur: BlurFit, bin_edges_nm: ArrayLike) -> list[str]:
    """A note naming the band where a field blur was measured, when the bundle's bins
    reach past it: its wavelength series is fitted through the lines' spots (the lasers',
    and the lamp lines' past them where the lamp frames hold field frames) and only
    continued linearly beyond them, unmeasured there (how far that is off on the design
    rigs: ``docs/notes/2026-11-30-singlet-snapshot-spectra.md``). The round blur's
    curve is the chromatic defocus law itself, so it gets no such note.

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> fit = SimpleNamespace(model=SimpleNamespace(kind="field_covariance"),
    ...                       wavelengths_nm=np.array([450.0, 532.0, 670.0]))
    >>> print(blur_band_notes(fit, [400.0, 500.0, 700.0])[0])  # doctest: +NORMALIZE_WHITESPACE
    blur: measured over the field at 3 lines, 450-670 nm; the bundle's bins reach
    400-700 nm, where its widths are extrapolated
    >>> blur_band_notes(fit, [450.0, 670.0])
    []
    """
    if blur.model.kind != "field_covariance":
        return []
    lines = np.asarray(blur.wavelengths_nm, dtype=np.float64)
    edges = np.asarray(bin_edges_nm, dtype=np.float64)
    low, high = float(lines.min()), float(lines.max())
    if edges.min() >= low and edges.max() <= high:
        return []
    return [
        f"blur: measured over the field at {lines.size} lines, {low:.0f}-{high:.0f} nm; the "
        f"bundle's bins reach {edges.min():.0f}-{edges.max():.0f} nm, where its widths are "
        "extrapolated"
    ]


def laser_line_notes(result: SpectralCalibration) -> list[str]:
    """What the laser-line check found, one sentence per line off its label.

    Parameters
    ----------
    result
        An analysed spectral calibration (its ``laser_lines``, fitted wavelengths and
        the procedure's ``tolerances.laser_line_nm``).

    Returns
    -------
    list of str
        A note for every line fitted at its estimate, placed by the maps and its test
        sheet (:func:`placed_line_note`), off its label by more than its check allows, or
        passed by a check wider than :data:`LOOSE_LINE_CHECK` times the tolerance (an end
        line far from the others: what would check it closer); empty when the labels
        agree closely. With lamp anchoring, every laser's measured line.

    Examples
    --------
    Not run here (it needs captured sessions)::

        laser_line_notes(result)
        # ['laser 635 nm: the other lines put it at 637.78 nm (+2.78 nm); ...']
    """
    if result.anchoring is not None:
        anchoring = result.anchoring
        fit = anchoring.measured or anchoring.fit
        anchors = ", ".join(sorted(fit.lamps))
        tolerance = float(result.procedure["tolerances"].get("laser_wavelength_sigma_nm", 0.5))
        notes = []
        for label, measured, sigma in zip(
            fit.labels_nm, fit.wavelengths_nm, fit.sigma_nm, strict=True
        ):
            note = (
                f"laser {label:g} nm: measured {measured:.2f} +- {sigma:.2f} nm against the "
                f"{anchors} lamp lines ({measured - label:+.2f} nm from its label"
            )
            if float(label) in anchoring.confirmed:
                note += "; label confirmed, fitted at it)"
            elif float(label) in anchoring.unpinned and abs(
                shift := anchoring.form_shift_nm.get(float(label), 0.0)
            ) > max(float(sigma), tolerance):
                note += (
                    f"; the measurement moves {shift:+.2f} nm when the column model gains a "
                    "power: the lamp lines near it blend at this dispersion and the model's "
                    "form, not the data, decides where, so it keeps its label. More lamp "
                    "frames do not help; a lamp with isolated lines near it, or a prism with "
                    "more spread there, would)"
                )
            elif float(label) in anchoring.unpinned:
                frames = math.ceil(anchoring.frames * (sigma / tolerance) ** 2)
                note += (
                    f"; the lamps cannot pin it within {tolerance:g} nm, so it keeps its label: "
                    "the lamp lines near it blend at this dispersion or are faint. To measure "
                    f"it, take about {frames} lamp frames (lamps.max_frames; the uncertainty "
                    "falls as one over the square root of the frames), use a lamp with "
                    "isolated lines near it, or a prism with more spread there)"
                )
            else:
                note += ")"
            notes.append(note)
        record = anchoring.record
        if record is not None:
            taken = (
                f"lamp frames: {record.frames} per lamp in {len(record.batches)} batch(es), "
                f"{record.outcome}"
            )
            advice = record.advice()
            notes.append(f"{taken}: {advice}" if advice else taken)
        return notes
    notes = []
    estimated = set(result.dispersion.estimated_lines)
    tolerance = float(result.procedure["tolerances"].get("laser_line_nm", 0.5))
    for label, line in result.laser_lines.items():
        placed = result.stated_lines.get(label)
        if placed is not None:
            notes.append(placed_line_note(placed))
        elif label in estimated:
            notes.append(
                f"laser {label:g} nm: fitted at {line.estimated_nm:.2f} nm, its wavelength as "
                f"estimated from the {', '.join(f'{x:g}' for x in line.from_lines)} nm lines "
                f"({line.offset_nm:+.2f} nm from its label)"
            )
            continue
        if not np.isfinite(line.estimated_nm):
            continue
        if abs(line.offset_nm) > (allowed := line.allowed_nm(tolerance)):
            cause = (
                "this line is off its label"
                if line.off_label
                else "one of the lines is off its label, which cannot be told from so few lines"
            )
            notes.append(
                f"laser {label:g} nm: the {', '.join(f'{x:g}' for x in line.from_lines)} nm "
                f"lines put it at {line.estimated_nm:.2f} nm ({line.offset_nm:+.2f} nm, "
                f"beyond the {allowed:.2f} nm allowed: {tolerance:g} nm and "
                f"{line.propagated_nm:.2f} nm for the others' stated accuracy): "
                f"{cause}. Fix: measure the line with a spectrometer and correct lasers_nm, "
                "or set fit.estimate_laser_wavelengths: true in the procedure"
            )
        elif placed is None and allowed > LOOSE_LINE_CHECK * tolerance:
            notes.append(_loose_line_note(label, line, allowed))
    return notes


def placed_line_note(line: StatedLine) -> str:
    """Where the maps and a line's test sheet together place it, and how sure that is.

    Examples
    --------
    >>> print(placed_line_note(StatedLine(441.93, 0.28, 441.531, 0.0098, -0.0098)))
    ... # doctest: +NORMALIZE_WHITESPACE
    laser 441.93 nm: the maps and its test sheet together place it at 441.53 +- 0.01 nm
    (-0.40 nm from the sheet's centre, 1.4 of the sheet's 0.28 nm sigmas); fitted there
    >>> print(placed_line_note(StatedLine(633.0, 0.28, 632.9, 0.27, 0.0)))
    ... # doctest: +NORMALIZE_WHITESPACE
    laser 633 nm: the maps and its test sheet together place it at 632.90 +- 0.27 nm
    (-0.10 nm from the sheet's centre, 0.4 of the sheet's 0.28 nm sigmas); fitted there.
    The maps add little to the sheet here: a laser line nearer it or wavelength lamps
    would pin it
    """
    note = (
        f"laser {line.label_nm:g} nm: the maps and its test sheet together place it at "
        f"{line.estimated_nm:.2f} +- {line.sigma_nm:.2f} nm ({line.moved_nm:+.2f} nm from the "
        f"sheet's centre, {abs(line.moved_nm) / line.stated_sigma_nm:.1f} of the sheet's "
        f"{line.stated_sigma_nm:g} nm sigmas); fitted there"
    )
    if line.sigma_nm > 0.5 * line.stated_sigma_nm:
        note += (
            ". The maps add little to the sheet here: a laser line nearer it or wavelength "
            "lamps would pin it"
        )
    return note


#: A laser line whose check allows more than this many times ``laser_line_nm`` (the
#: others' accuracy, propagated to it, moves their estimate that far) gets a note.
LOOSE_LINE_CHECK = 2.0


def _loose_line_note(label: float, line: LaserLine, allowed: float) -> str:
    """Why a line passed a check this wide, and what would check it closer."""
    others = line.from_lines
    outside = label < min(others) or label > max(others)
    nearest = min(others, key=lambda x: abs(x - label))
    where = (
        f"an extrapolation {abs(nearest - label):.0f} nm beyond the nearest, {nearest:g} nm"
        if outside
        else f"{abs(nearest - label):.0f} nm from the nearest, {nearest:g} nm"
    )
    return (
        f"laser {label:g} nm: checked only within {allowed:.2f} nm: the "
        f"{', '.join(f'{x:g}' for x in others)} nm lines put it at {line.estimated_nm:.2f} nm "
        f"({line.offset_nm:+.2f} nm), but their stated accuracy, carried through the fit, "
        f"moves that estimate by {line.propagated_nm:.2f} nm there ({where}), so its label "
        "rests on its own "
        "measurement (a test sheet's centre, lasers_nm). To check it closer, add a laser "
        "line nearer it or wavelength lamps, or state the other lines' accuracy "
        "(laser_tolerance_nm) if it is better than the check's"
    )
