"""Checks that measure the bundle against what it is used for, and what to do when one fails.

- **The map's stated uncertainty.** The dispersion fit states the 1-sigma of the column it
  predicts at the field centre over 400-700 nm
  (:attr:`~sassi_bench.calibrate.dispersion.DispersionFit.position_sigma_px`: each
  laser map's error one smooth surface over the field, as large as the lines' scatter
  about the joint model or the map's own correspondence scatter, carried through the
  fit). A bundle places streaks to a tenth of a pixel and is graded on its wavelengths'
  RMS over the band against 0.3 nm; a map whose own 1-sigma exceeds either is expected to
  miss it (``tolerances.map_sigma_px`` on the column 1-sigma's RMS over the band,
  ``tolerances.map_sigma_nm`` on the RMS over the band of each wavelength's 1-sigma
  over its local dispersion). A tolerance on the worst over the band fails right
  bundles whose lasers stop short of the band's ends, where the 1-sigma is largest
  (at the blue end, where the dispersion is steepest, in px most of all). For a
  lamp-anchored map it counts the laser maps' errors as the anchored fit carries them,
  the lamp streaks' photon noise, and how far the column's form misses the described
  optics where the anchored fit's weighting puts the miss
  (:func:`~sassi_bench.calibrate.anchored_form.anchored_form_error_px`: noise-free, the
  miss lands where the lamp lines are thin or blended, often the red end).
- **The lines' own wavelengths, recorded.** What the lasers' wavelength uncertainty (a
  test sheet's accuracy as the rig states it, a lamp measurement's 1-sigma, for a label
  the lamps confirm the measurement's:
  :attr:`~sassi_bench.reduce.lamps.LampAnchoring.line_sigma_by_label`) moves the map by
  (:attr:`~sassi_bench.calibrate.dispersion.DispersionFit.line_sigma_nm`) is recorded
  and noted above ``LINE_SIGMA_NOTE_NM`` (:func:`line_uncertainty_notes`), not graded:
  a map whose lines are off by their accuracy and one whose lines happen to be right
  state the same, so a tolerance on it fails right bundles as often as wrong ones.
- **Lamp lines against their own uncertainty.** Every lamp line bright enough to tell has a
  residual from where the map puts it and a 1-sigma from its photons (scaled by its
  lamp's reduced chi-square). Against the line's width (``lamp_line_rms_fwhm``) a wrong
  glass hides at low dispersion: the lasers, free within their diodes' tolerance, and
  the dense lines elsewhere bend the map to the described glass's curve, and the line
  left over at the band's end sits a few hundredths of its FWHM off, yet many of its
  own sigmas, where the right glass leaves every line within one
  (``docs/notes/2026-12-01-measured-in-code-comments.md``). So the largest
  ``|residual| / sigma`` is checked (``tolerances.lamp_line_max_sigmas``), and a failure
  names the glass first: it is the one stated value that bends the map's curve.
  A line's 1-sigma includes how far the column model's form misses the described arm
  (:func:`~sassi_bench.reduce.lamps.described_form_misfit_nm`, in quadrature): where
  the form cannot follow the optics (the achromat arm:
  ``docs/notes/2026-11-29-achromat-wavelength-map.md``), a line sits off the map by that
  much whatever the glass, and the check would fail a right bundle.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from sassi_bench.bundle import QualityCheck
from sassi_bench.calibrate.dispersion import DispersionFit
from sassi_bench.reduce.lamps import LampAnchoring

__all__ = [
    "LAMP_LINE_MAX_SIGMAS",
    "LINE_SIGMA_NOTE_NM",
    "MAP_SIGMA_NM",
    "MAP_SIGMA_PX",
    "LampLineOutlier",
    "bundle_check_notes",
    "line_uncertainty_notes",
    "map_sigma_nm",
    "measured_bundle_checks",
    "worst_lamp_line",
]

#: The map's column 1-sigma (camera px, RMS over the band) when the procedure names none:
#: the 0.1 px a bundle places streaks to.
MAP_SIGMA_PX = 0.1
#: The map's 1-sigma (nm, RMS over the band) when the procedure names none: the 0.3 nm its
#: wavelengths are graded to.
MAP_SIGMA_NM = 0.3
#: What the laser lines' own wavelength uncertainty may carry into the map (nm RMS over
#: the band) before a note says how to pin them: half the 0.3 nm the map is graded to.
LINE_SIGMA_NOTE_NM = 0.15
#: How many of its own sigmas a lamp line may sit off the map when the procedure names none.
LAMP_LINE_MAX_SIGMAS = 5.0


@dataclass(frozen=True)
class LampLineOutlier:
    """The lamp line furthest from the map in units of its own 1-sigma.

    Attributes
    ----------
    lamp, line_nm
        The lamp and the line's table wavelength.
    residual_nm, sigma_nm
        Its residual from where the map puts it and its 1-sigma (nm): its photons' and
        the column model's form misfit on the described arm, in quadrature.
    """

    lamp: str
    line_nm: float
    residual_nm: float
    sigma_nm: float

    @property
    def sigmas(self) -> float:
        """``|residual| / sigma``."""
        return abs(self.residual_nm) / self.sigma_nm


def worst_lamp_line(anchoring: LampAnchoring) -> LampLineOutlier | None:
    """The lamp line furthest from the map in its own sigmas (None without a told line).

    Examples
    --------
    Not run here (it needs captured sessions)::

        worst_lamp_line(result.anchoring).sigmas
        # 0.23
    """
    form_nm = anchoring.form_misfit_nm or 0.0
    lines = [
        LampLineOutlier(lamp, lam, residual, float(np.hypot(sigma, form_nm)))
        for lamp, told in anchoring.line_residuals_nm().items()
        for lam, (residual, sigma) in told.items()
        if np.isfinite(residual) and np.isfinite(sigma) and sigma > 0
    ]
    return max(lines, key=lambda line: line.sigmas, default=None)


def map_sigma_nm(fit: DispersionFit) -> float:
    """The map's stated 1-sigma in nm: at each wavelength of 400-700 nm the column's
    1-sigma at the field centre over the local dispersion there (px per nm), RMS over the
    band, the statistic the map's wavelengths are graded by.

    Taken wavelength by wavelength: the column is least sure where the map reaches past
    its lines (often the blue end), the dispersion lowest at the red end, and the worst of
    one over the worst of the other would state a 1-sigma the map has nowhere.

    Examples
    --------
    Not run here (it needs captured sessions)::

        map_sigma_nm(result.dispersion)
        # 0.0012
    """
    return fit.position_sigma_rms_nm


def measured_bundle_checks(
    fit: DispersionFit, anchoring: LampAnchoring | None, tolerances: Mapping[str, float]
) -> list[QualityCheck]:
    """The map's stated 1-sigma in px and nm and, with lamps, the lamp line furthest from
    the map in its own sigmas.

    Parameters
    ----------
    fit
        The dispersion fit.
    anchoring
        The lamp anchoring, if any.
    tolerances
        The spectral procedure's ``tolerances``.

    Returns
    -------
    list of QualityCheck
        ``map_sigma_px``, ``map_sigma_nm`` and, with lamps, ``lamp_line_max_sigmas``.

    Examples
    --------
    Not run here (it needs captured sessions)::

        [c.name for c in measured_bundle_checks(result.dispersion, None, tolerances)]
        # ['map_sigma_px', 'map_sigma_nm']
    """
    checks = [
        QualityCheck.at_most(
            "map_sigma_px",
            fit.position_sigma_rms_px,
            float(tolerances.get("map_sigma_px", MAP_SIGMA_PX)),
            "px",
        ),
        QualityCheck.at_most(
            "map_sigma_nm",
            map_sigma_nm(fit),
            float(tolerances.get("map_sigma_nm", MAP_SIGMA_NM)),
            "nm",
        ),
    ]
    worst = worst_lamp_line(anchoring) if anchoring is not None else None
    if worst is not None:
        checks.append(
            QualityCheck.at_most(
                "lamp_line_max_sigmas",
                worst.sigmas,
                float(tolerances.get("lamp_line_max_sigmas", LAMP_LINE_MAX_SIGMAS)),
                "1",
            )
        )
    return checks


def bundle_check_notes(
    checks: list[QualityCheck],
    fit: DispersionFit,
    anchoring: LampAnchoring | None,
    glass: str,
) -> list[str]:
    """A note for every failed check of :func:`measured_bundle_checks`: the physical cause
    and the fix a person can carry out.

    Parameters
    ----------
    checks
        The calibration's checks (those of :func:`measured_bundle_checks` are read).
    fit, anchoring
        The dispersion fit and the lamp anchoring.
    glass
        The prism's glass as described (``prism.glass``).

    Examples
    --------
    >>> bundle_check_notes([], None, None, "F2")
    []
    """
    failed = {c.name: c for c in checks if not c.passed}
    notes = []
    if "map_sigma_px" in failed or "map_sigma_nm" in failed:
        notes.append(
            f"wavelength map: it states +-{fit.position_sigma_rms_px:.3f} px "
            f"(+-{map_sigma_nm(fit):.3f} nm) RMS over the band, more than the bundle is "
            "used for: the laser maps scatter about the joint dispersion model, or their own "
            "correspondences scatter, and the lines stop short of the band's ends. "
            "Fix: check each laser's correspondence residual (a noisy or clipped sweep: a "
            "longer or shorter exposure), add a laser line towards the band's ends or "
            "wavelength lamps (wavelength_lamps), or lower fit.dispersion_order with fewer "
            "lines"
        )
    worst = worst_lamp_line(anchoring) if anchoring is not None else None
    if "lamp_line_max_sigmas" in failed and worst is not None:
        notes.append(
            f"lamp line {worst.lamp} {worst.line_nm:.1f} nm: {worst.residual_nm:+.3f} nm "
            f"(+-{worst.sigma_nm:.3f} nm, {worst.sigmas:.0f} sigma) from where the map puts it, "
            "though small against its width: the map's curve across the band does not follow "
            f"the bench. The prism's glass may not be the one described ({glass}): the map "
            "follows the described glass's dispersion and the lasers, free within their "
            "tolerance, absorb the difference. Fix: check prism.glass against the prism's "
            "datasheet or melt sheet and calibrate again; if the glass is right, check the "
            f"{worst.lamp} table near {worst.line_nm:.0f} nm (a line missing from it blends "
            "into this one at this dispersion)" + _lamp_fit_clause(anchoring)
        )
    return notes


def _lamp_fit_clause(anchoring: LampAnchoring) -> str:
    """How well each lamp's streaks fit, for the lamp-line note: a lamp that fits far worse
    than the other had lines taken for their neighbours
    (docs/notes/2026-11-30-rig-family-lamps.md)."""
    chi2 = {name: fit.chi2 for name, fit in anchoring.fit.lamps.items()}
    if len(chi2) < 2:
        return ""
    told = ", ".join(f"{name} {value:.1f}" for name, value in chi2.items())
    return (
        f". The lamps' streaks fit with reduced chi-squares of {told}: where one lamp fits "
        "far worse than the other, its lines were taken for their neighbours, and the "
        "lasers, free within their labels' tolerance, followed; state the lasers' lines "
        "as measured (laser_tolerance_nm) and calibrate again"
    )


def line_uncertainty_notes(fit: DispersionFit) -> list[str]:
    """A note when the laser lines' own wavelength uncertainty carries more than
    :data:`LINE_SIGMA_NOTE_NM` RMS into the map over 400-700 nm (recorded in the bundle as
    ``line_sigma_nm``, not graded: no check can tell a map whose lines are off by their
    stated accuracy from one whose lines happen to be right).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> fit = SimpleNamespace(line_sigma_nm=0.26, line_sigma_max_nm=0.6)
    >>> print(line_uncertainty_notes(fit)[0])  # doctest: +ELLIPSIS
    wavelength map: the laser lines' own wavelengths carry +-0.26 nm RMS into it over ...
    >>> line_uncertainty_notes(SimpleNamespace(line_sigma_nm=0.02, line_sigma_max_nm=0.05))
    []
    """
    if fit.line_sigma_nm <= LINE_SIGMA_NOTE_NM:
        return []
    return [
        f"wavelength map: the laser lines' own wavelengths carry +-{fit.line_sigma_nm:.2f} nm "
        f"RMS into it over 400-700 nm (+-{fit.line_sigma_max_nm:.2f} nm at worst, where it "
        "reaches past its lines), as the rig states them (laser_tolerance_nm) or the lamps "
        f"measure them: more than half the {MAP_SIGMA_NM:g} nm the map is graded to. "
        "To pin them: wavelength lamps on the diffuser, a spectrometer's reading of each "
        "line, or a laser nearer the band's open end"
    ]


def off_label_notes(
    checks: list[QualityCheck], anchoring: LampAnchoring | None, glass: str
) -> list[str]:
    """A note when the lamps measure lasers off their stated lines by more than the rig
    allows (failed ``laser_label_<nm>`` checks), naming both causes a person can check.

    The map follows the described glass's dispersion, and the fit moves the lasers to
    absorb a glass that is not the bench's: the lines furthest from the band's middle
    move most, one way at each end. With lasers stated to their test sheets' accuracy
    this is how a wrong glass shows; with diode labels (a few nm) it cannot
    (docs/notes/2026-11-30-wrong-glass-spread.md).

    Examples
    --------
    >>> from types import SimpleNamespace
    >>> fit = SimpleNamespace(labels_nm=[450.0, 670.0], wavelengths_nm=[450.0, 674.2])
    >>> failed = [QualityCheck.at_most("laser_label_670nm", 4.2, 0.49, "nm")]
    >>> anchoring = SimpleNamespace(measured=fit)
    >>> print(off_label_notes(failed, anchoring, "N-SF11")[0])  # doctest: +ELLIPSIS
    laser 670 nm: the lamps measure it +4.20 nm from its stated line, ... (N-SF11)...
    """
    failed = {c.name for c in checks if not c.passed and c.name.startswith("laser_label_")}
    if not failed or anchoring is None:
        return []
    fit = anchoring.measured or anchoring.fit
    off = [
        (float(label), float(measured) - float(label))
        for label, measured in zip(fit.labels_nm, fit.wavelengths_nm, strict=True)
        if f"laser_label_{float(label):g}nm" in failed
    ]
    lines = ", ".join(f"{label:g}" for label, _ in off)
    shifts = ", ".join(f"{shift:+.2f}" for _, shift in off)
    which, whose = ("it", "its") if len(off) == 1 else ("them", "their")
    return [
        f"laser {lines} nm: the lamps measure {which} {shifts} nm from {whose} stated line, "
        "more than the rig's laser_tolerance_nm allows. Either a line is not "
        "where the rig states it, or the map's curve across the band does not follow the "
        f"bench: the prism's glass may not be the one described ({glass}), and the fit "
        "moves the lasers to absorb it (those furthest from the band's middle most). Fix: "
        "check prism.glass against the prism's datasheet or melt sheet and each laser's "
        "line against its test sheet (or a spectrometer), then calibrate again"
    ]
