"""The analysis stage of the spectral calibration: sweeps -> dispersion, blur, checks.

:func:`analyse_spectral_sweeps` decodes the captured sweeps
(:mod:`sassi_bench.workflows.spectral_decode`), checks the laser lines against each
other, fits the joint dispersion model and the blur, and grades the result against the
procedure's tolerances (:func:`grade`). Fit settings and tolerances may differ from
those the sweeps were captured with (a region excluded in the notebook).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationModels, QualityCheck
from sassi_bench.calibrate.blur import BlurFit
from sassi_bench.calibrate.dispersion import (
    DispersionFit,
    LaserLine,
    check_laser_lines,
    fit_dispersion,
)
from sassi_bench.calibrate.grey_response import GreyResponse
from sassi_bench.workflows.spectral_capture import SpectralSweeps
from sassi_bench.workflows.spectral_decode import (
    LaserDecode,
    analyse_sweep,
    blur_from_pinholes,
    measure_response,
)

__all__ = ["SpectralCalibration", "analyse_spectral_sweeps", "grade", "laser_line_notes"]


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
        >>> result.models().bins.count  # doctest: +SKIP
        68
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
        put it from its label. A line fitted at its estimate has no such check (it
        agrees with the others by construction); the bundle records its estimate.

    Returns
    -------
    list of QualityCheck

    Examples
    --------
    >>> checks = grade(result.lasers, result.dispersion, result.blur, tolerances)  # doctest: +SKIP
    >>> all(check.passed for check in checks)  # doctest: +SKIP
    True
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
    estimated = set(dispersion.estimated_lines)
    for label, line in (laser_lines or {}).items():
        if label not in estimated and np.isfinite(line.estimated_nm):
            checks.append(
                QualityCheck.at_most(
                    f"laser_line_{label:g}nm",
                    abs(line.offset_nm),
                    tolerances.get("laser_line_nm", 0.5),
                    "nm",
                )
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
    return checks


def analyse_spectral_sweeps(
    sweeps: SpectralSweeps, procedure: Mapping[str, Any], rig_description: Any
) -> SpectralCalibration:
    """Decode the sweeps, fit the dispersion and blur models and grade them.

    Parameters
    ----------
    sweeps
        From :func:`~sassi_bench.workflows.spectral_capture.capture_spectral_sweeps`.
    procedure
        The procedure the sweeps were captured with (fit settings and tolerances).
    rig_description
        The rig's description (SLM shape, camera bit depth, prism glass).

    Returns
    -------
    SpectralCalibration

    Examples
    --------
    >>> result = analyse_spectral_sweeps(sweeps, proc, rig.description)  # doctest: +SKIP
    >>> result.passed  # doctest: +SKIP
    True
    """
    proc = dict(procedure)
    desc = rig_description
    slm_shape = (desc.slm.height, desc.slm.width)
    saturation = 2**desc.spectral_camera.bit_depth - 1
    response = measure_response(sweeps.grey, saturation) if sweeps.grey is not None else None
    decoded = analyse_sweep(sweeps.sweep, proc, slm_shape, saturation)
    maps = [d.laser_map for d in decoded]
    shape = {
        "field_degree": int(proc["fit"].get("field_degree", 5)),
        "order": int(proc["fit"].get("dispersion_order", 2)),
    }
    lines = check_laser_lines(
        maps,
        desc.prism.glass,
        slm_shape,
        float(proc["tolerances"].get("laser_line_nm", 0.5)),
        **shape,
    )
    estimate = bool(proc["fit"].get("estimate_laser_wavelengths", False))
    dispersion = fit_dispersion(
        maps,
        desc.prism.glass,
        slm_shape,
        wavelengths_nm={k: v.estimated_nm for k, v in lines.items() if v.off_label}
        if estimate
        else None,
        **shape,
    )
    blur = blur_from_pinholes(sweeps.sweep, proc, dispersion, slm_shape, saturation)
    checks = grade(decoded, dispersion, blur, proc["tolerances"], lines)
    return SpectralCalibration(
        proc,
        desc,
        decoded,
        dispersion,
        blur,
        response,
        checks,
        sweeps.sessions,
        laser_lines=lines,
    )


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
        A note for every line fitted at its estimate or off its label by more than
        the tolerance; empty when the labels agree.

    Examples
    --------
    >>> laser_line_notes(result)  # doctest: +SKIP
    ['laser 635 nm: the other lines put it at 637.78 nm (+2.78 nm); ...']
    """
    notes = []
    estimated = set(result.dispersion.estimated_lines)
    tolerance = float(result.procedure["tolerances"].get("laser_line_nm", 0.5))
    for label, line in result.laser_lines.items():
        if label in estimated:
            notes.append(
                f"laser {label:g} nm: fitted at {line.estimated_nm:.2f} nm, its wavelength as "
                f"estimated from the {', '.join(f'{x:g}' for x in line.from_lines)} nm lines "
                f"({line.offset_nm:+.2f} nm from its label)"
            )
        elif abs(line.offset_nm) > tolerance:
            cause = (
                "this line is off its label"
                if line.off_label
                else "one of the lines is off its label, which cannot be told from so few lines"
            )
            notes.append(
                f"laser {label:g} nm: the {', '.join(f'{x:g}' for x in line.from_lines)} nm "
                f"lines put it at {line.estimated_nm:.2f} nm ({line.offset_nm:+.2f} nm): "
                f"{cause}. Fix: measure the line with a spectrometer and correct lasers_nm, "
                "or set fit.estimate_laser_wavelengths: true in the procedure"
            )
    return notes
