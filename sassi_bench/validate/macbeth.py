"""Macbeth ColorChecker validation: measured reflectances against reference data.

A scan of the chart under a white LED gives a cube; dividing it by a white reference
measured through the same chain (a white diffuser scanned under the same light, or the
chart's own white patch with its reference reflectance) cancels the light and the
system's response and leaves reflectance. Each patch's interior gives a mean spectrum and
its spread; each is compared with reference reflectances averaged over the same bins:

* spectral angle and RMSE, only in the *usable band*, the bins where the white reference
  has at least a set fraction of its peak signal (CIE LED spectra have almost no power
  near 400 nm, where a ratio is noise);
* CIEDE2000 under D65 for the CIE 1931 2 degree observer, from the usable band of both
  spectra (held constant beyond it).

Tolerances and pass/fail come from the procedure (``procedures/macbeth_validation.yaml``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle import QualityCheck
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.angles import spectral_angle_deg
from sassi_bench.validate.colorimetry import (
    delta_e2000,
    reflectance_to_lab,
    reflectance_to_srgb,
    rmse,
)
from sassi_bench.validate.locate import ChartGrid
from sassi_bench.validate.reference import PATCH_COUNT, WHITE_PATCH, ReferenceChart

__all__ = [
    "MacbethResult",
    "PatchStatistics",
    "noise_floor",
    "patch_statistics",
    "standard_error",
    "validate_macbeth",
]


@dataclass(frozen=True)
class PatchStatistics:
    """Per-patch mean and standard deviation of a cube's spectra over patch interiors.

    Attributes
    ----------
    mean, std
        (24, B) float64.
    count
        (24,) pixels averaged per patch.
    """

    mean: NDArray[np.float64]
    std: NDArray[np.float64]
    count: NDArray[np.intp]


def patch_statistics(
    cube: NDArray[Any], quality: NDArray[Any], labels: NDArray[np.intp]
) -> PatchStatistics:
    """Mean and spread of the good pixels' spectra inside each patch's interior.

    Parameters
    ----------
    cube
        (H, W, B) spectra.
    quality
        (H, W) quality mask; 0 = good.
    labels
        (H, W) patch index 0-23 or -1 (:meth:`ChartGrid.labels`).

    Examples
    --------
    >>> cube = np.arange(12.0).reshape(2, 3, 2)
    >>> labels = np.array([[0, 0, -1], [1, 1, 1]])
    >>> s = patch_statistics(cube, np.zeros((2, 3)), labels)
    >>> s.mean[:2].tolist(), s.count[:2].tolist()
    ([[1.0, 2.0], [8.0, 9.0]], [2, 3])
    """
    good = (np.asarray(quality) == 0) & (labels >= 0) & np.all(np.isfinite(cube), axis=-1)
    lab = labels[good]
    spectra = np.asarray(cube)[good].astype(np.float64)  # the good pixels only, then float64
    count = np.bincount(lab, minlength=PATCH_COUNT)[:PATCH_COUNT]
    n = np.maximum(count, 1)[:, None]
    total = np.zeros((PATCH_COUNT, spectra.shape[1]))
    square = np.zeros_like(total)
    np.add.at(total, lab, spectra)
    np.add.at(square, lab, spectra**2)
    mean = total / n
    std = np.sqrt(np.clip(square / n - mean**2, 0.0, None))
    return PatchStatistics(mean, std, count)


@dataclass
class MacbethResult:
    """Everything the validation measured, compared and decided.

    Attributes
    ----------
    wavelengths_nm, bin_edges_nm
        The bundle's bins (B,), (B + 1,).
    usable
        (B,) bins inside the usable band.
    white_relative
        (B,) white reference signal relative to its peak (how the band was chosen).
    reflectance, spread
        (24, B) measured mean reflectance and its standard deviation over the patch.
    reference
        (24, B) reference reflectance averaged over the bins.
    pixels
        (24,) pixels averaged per patch.
    angle_deg, rmse, de00
        (24,) per patch, in the usable band.
    lab_measured, lab_reference
        (24, 3) CIELAB (D65, CIE 1931 2 degree).
    srgb_measured, srgb_reference
        (24, 3) display sRGB of the same colours.
    noise
        Estimated noise floor of every per-patch figure, ``{"angle_deg", "rmse",
        "de00"}`` -> (24,): what photon and read noise alone would give a perfect
        calibration (see :func:`noise_floor`).
    checks
        Tolerance checks from the procedure.
    settings
        How the validation was run (reference data, white reference, localisation, ...).
    notes
        Sentences the report must say (the band, what is and is not compared).
    picture, picture_origin
        The picture the patches were found on (H, W, 3 display sRGB) and the SLM (row,
        column) of its first pixel, for the report; None when not kept.
    """

    wavelengths_nm: NDArray[np.float64]
    bin_edges_nm: NDArray[np.float64]
    usable: NDArray[np.bool_]
    white_relative: NDArray[np.float64]
    reflectance: NDArray[np.float64]
    spread: NDArray[np.float64]
    reference: NDArray[np.float64]
    pixels: NDArray[np.intp]
    angle_deg: NDArray[np.float64]
    rmse: NDArray[np.float64]
    de00: NDArray[np.float64]
    lab_measured: NDArray[np.float64]
    lab_reference: NDArray[np.float64]
    srgb_measured: NDArray[np.float64]
    srgb_reference: NDArray[np.float64]
    patch_names: tuple[str, ...]
    checks: list[QualityCheck]
    settings: dict[str, Any]
    grid: ChartGrid
    noise: dict[str, NDArray[np.float64]] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    picture: NDArray[np.float32] | None = None
    picture_origin: tuple[int, int] = (0, 0)

    @property
    def passed(self) -> bool:
        """True if every tolerance check passed."""
        return all(c.passed for c in self.checks)

    @property
    def band_nm(self) -> tuple[float, float]:
        """Centres of the first and last usable bins."""
        lam = self.wavelengths_nm[self.usable]
        return float(lam[0]), float(lam[-1])

    def summary(self) -> dict[str, float]:
        """The headline numbers."""
        return {
            "mean_de00": float(np.mean(self.de00)),
            "max_de00": float(np.max(self.de00)),
            "mean_spectral_angle_deg": float(np.mean(self.angle_deg)),
            "max_spectral_angle_deg": float(np.max(self.angle_deg)),
            "mean_rmse": float(np.mean(self.rmse)),
            "max_rmse": float(np.max(self.rmse)),
        }

    def noise_floors(self) -> dict[str, float]:
        """The noise floor beside each tolerance check's figure (same names as the checks).

        A figure over patches (mean, max) gets the same statistic of the per-patch
        floors; for a mean this is an upper bound (noise averages down over patches).
        """
        if not self.noise:
            return {}
        return {
            "mean_de00": float(np.mean(self.noise["de00"])),
            "max_de00": float(np.max(self.noise["de00"])),
            "mean_spectral_angle": float(np.mean(self.noise["angle_deg"])),
            "max_rmse": float(np.max(self.noise["rmse"])),
        }


def noise_floor(
    reflectance: NDArray[np.float64],
    standard_error: NDArray[np.float64],
    wavelengths_nm: NDArray[np.float64],
    draws: int = 64,
    seed: int = 0,
) -> dict[str, NDArray[np.float64]]:
    """What noise alone does to each patch's spectral angle, RMSE and CIEDE2000, (24,) each.

    Parameters
    ----------
    reflectance
        (24, B) measured reflectance in the usable band.
    standard_error
        (24, B) standard error of each value: the patch's pixel spread over the square
        root of its pixel count, combined with the white reference's.
    wavelengths_nm
        (B,) bin centres.
    draws, seed
        Monte Carlo draws for CIEDE2000 and the angle (deterministic).

    Returns
    -------
    dict
        ``"rmse"``: the RMS of the standard errors (the RMSE a perfect calibration would
        show); ``"angle_deg"`` and ``"de00"``: the RMS change of the angle to the
        measurement itself and of the colour difference when the measurement is
        perturbed by its standard errors.

    Examples
    --------
    >>> r = np.full((24, 3), 0.5)
    >>> floor = noise_floor(r, np.full((24, 3), 0.01), np.array([450.0, 550.0, 650.0]))
    >>> round(float(floor["rmse"][0]), 4), bool(floor["de00"][0] > 0)
    (0.01, True)
    """
    r = np.asarray(reflectance, dtype=np.float64)
    se = np.nan_to_num(np.asarray(standard_error, dtype=np.float64))
    rng = np.random.default_rng(seed)
    perturbed = r[None] + se[None] * rng.standard_normal((draws, *r.shape))
    flat = perturbed.reshape(-1, r.shape[1])
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    angle = spectral_angle_deg(flat, np.broadcast_to(r, perturbed.shape).reshape(flat.shape))
    lab = reflectance_to_lab(lam, flat).reshape(draws, r.shape[0], 3)
    de = delta_e2000(lab, np.broadcast_to(reflectance_to_lab(lam, r), lab.shape))
    return {
        "rmse": np.sqrt(np.mean(se**2, axis=1)),
        "angle_deg": np.sqrt(np.mean(angle.reshape(draws, -1) ** 2, axis=0)),
        "de00": np.sqrt(np.mean(de**2, axis=0)),
    }


def _usable_band(white: NDArray[np.float64], min_relative: float) -> NDArray[np.bool_]:
    """The longest run of bins whose white signal is at least ``min_relative`` of its peak."""
    ok = white >= min_relative * np.max(white)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    starts, stops = edges[::2], edges[1::2]
    if starts.size == 0:
        return ok
    k = int(np.argmax(stops - starts))
    band = np.zeros_like(ok)
    band[starts[k] : stops[k]] = True
    return band


def validate_macbeth(
    chart: PatchStatistics,
    white: NDArray[np.float64],
    reference: ReferenceChart,
    bin_edges_nm: NDArray[np.float64],
    wavelengths_nm: NDArray[np.float64],
    procedure: Mapping[str, Any],
    grid: ChartGrid,
    settings: Mapping[str, Any] | None = None,
    white_error: NDArray[np.float64] | None = None,
) -> MacbethResult:
    """Reflectance of every patch, compared with the reference and graded.

    Parameters
    ----------
    chart
        Per-patch statistics of the chart scan (:func:`patch_statistics`).
    white
        The white reference in the chart scan's units: (B,) or (24, B) signal of a perfect
        white (a diffuser's signal divided by its reflectance, per patch position; or the
        white patch's signal divided by its reference reflectance).
    reference
        Reference reflectances.
    bin_edges_nm, wavelengths_nm
        The bundle's bins.
    procedure
        The validated ``macbeth_validation`` procedure (tolerances, usable band).
    grid
        Where the patches were found (kept for the report).
    settings
        Extra provenance for the report.
    white_error
        Standard error of ``white``, same shape (from its pixel spread); with it the
        noise floor of every figure is estimated and checked against
        ``tolerances.max_noise_fraction`` of each tolerance, so a noisy scan fails a
        check that says so instead of passing or failing a tolerance on noise.

    Returns
    -------
    MacbethResult
    """
    white = np.asarray(white, dtype=np.float64)
    white_mean = white if white.ndim == 1 else np.mean(white, axis=0)
    if not np.all(np.isfinite(white_mean)) or np.max(white_mean) <= 0:
        raise ProcedureError(
            step_error(
                "Macbeth validation",
                "the white reference has no positive signal",
                "check the white reference capture (light on, diffuser in view)",
            )
        )
    if np.any(chart.count == 0):
        missing = ", ".join(str(i + 1) for i in np.flatnonzero(chart.count == 0))
        raise ProcedureError(
            step_error(
                "Macbeth validation",
                f"no measured pixels inside patch(es) {missing}",
                "check the patch localisation (give --corners) and that the scan covers the chart",
            )
        )
    band_rule = procedure["usable_band"]
    relative = white_mean / np.max(white_mean)
    usable = _usable_band(relative, float(band_rule["min_relative_signal"]))
    safe_white = np.where(white > 0, white, np.nan)
    reflectance = chart.mean / safe_white
    spread = chart.std / safe_white
    ref = reference.bin_average(bin_edges_nm)
    lam = np.asarray(wavelengths_nm, dtype=np.float64)
    m, r = reflectance[:, usable], ref[:, usable]
    angle = spectral_angle_deg(m, r)
    error = rmse(m, r)
    lab_m = reflectance_to_lab(lam[usable], m)
    lab_r = reflectance_to_lab(lam[usable], r)
    de = delta_e2000(lab_m, lab_r)
    tol = procedure["tolerances"]
    checks = [
        QualityCheck.at_most("mean_de00", float(np.mean(de)), tol["mean_de00"], "dE00"),
        QualityCheck.at_most("max_de00", float(np.max(de)), tol["max_de00"], "dE00"),
        QualityCheck.at_most(
            "mean_spectral_angle", float(np.mean(angle)), tol["mean_spectral_angle_deg"], "deg"
        ),
        QualityCheck.at_most("max_rmse", float(np.max(error)), tol["max_rmse"], "1"),
    ]
    noise: dict[str, NDArray[np.float64]] = {}
    if white_error is not None:
        white_se = np.asarray(white_error, dtype=np.float64)
        chart_se = standard_error(chart)
        relative_error = np.hypot(chart_se / chart.mean, white_se / white)
        noise = noise_floor(m, (np.abs(reflectance) * relative_error)[:, usable], lam[usable])
    band = (float(lam[usable][0]), float(lam[usable][-1]))
    notes = [
        f"Spectra are compared only in the usable band {band[0]:.0f}-{band[1]:.0f} nm "
        f"({int(usable.sum())} of {lam.size} bins), where the white reference reaches at least "
        f"{100 * float(band_rule['min_relative_signal']):g} % of its peak: the light has too "
        "little power outside it for a ratio to mean anything.",
        "CIEDE2000 is computed under D65 for the CIE 1931 2 degree observer from the usable band "
        "of both spectra, each held constant beyond it; the reference is averaged over the "
        "bundle's bins exactly like the measurement.",
    ]
    few = np.flatnonzero(chart.count < 0.5 * np.median(chart.count))
    if few.size:
        listed = ", ".join(f"{i + 1} ({int(chart.count[i])} px)" for i in few)
        notes.append(
            f"Patch(es) {listed} kept less than half the usual pixels: the scan flagged the "
            "rest (saturated, off the camera or not measured); check the exposure."
        )
    if white.ndim == 1 and (settings or {}).get("white_reference") == "patch":
        notes.append(
            f"The white reference is the chart's white patch ({reference.patch_names[WHITE_PATCH]})"
            " with its reference reflectance, so that patch agrees by construction."
        )
    result = MacbethResult(
        wavelengths_nm=lam,
        bin_edges_nm=np.asarray(bin_edges_nm, dtype=np.float64),
        usable=usable,
        white_relative=relative,
        reflectance=reflectance,
        spread=spread,
        reference=ref,
        pixels=chart.count,
        angle_deg=angle,
        rmse=error,
        de00=de,
        lab_measured=lab_m,
        lab_reference=lab_r,
        srgb_measured=reflectance_to_srgb(lam[usable], m),
        srgb_reference=reflectance_to_srgb(lam[usable], r),
        patch_names=reference.patch_names,
        checks=checks,
        settings=dict(settings or {}),
        grid=grid,
        notes=notes,
        noise=noise,
    )
    if noise:
        notes.append(
            "The noise floor beside each figure is what the scans' photon and read noise alone "
            "would give a perfect calibration (each patch's pixel spread over the square root "
            "of its pixel count, with the white reference's, propagated to the figure); a "
            "figure well above its floor is calibration error."
        )
        result.checks.append(_noise_check(result, tol, notes))
    return result


# The checks' tolerance keys in the procedure.
_TOLERANCE_KEYS = {
    "mean_de00": "mean_de00",
    "max_de00": "max_de00",
    "mean_spectral_angle": "mean_spectral_angle_deg",
    "max_rmse": "max_rmse",
}


def _noise_check(result: MacbethResult, tol: Mapping[str, Any], notes: list[str]) -> QualityCheck:
    """The largest noise floor as a fraction of its tolerance, against the allowed share."""
    floors = result.noise_floors()
    shares = {name: floors[name] / float(tol[key]) for name, key in _TOLERANCE_KEYS.items()}
    worst = max(shares, key=shares.get)
    allowed = float(tol.get("max_noise_fraction", 0.25))
    check = QualityCheck.at_most("noise_floor_fraction", shares[worst], allowed, "1")
    if not check.passed:
        notes.append(
            f"The scan is too noisy to judge the calibration: the noise floor of {worst} "
            f"({floors[worst]:.3g}) is {100 * shares[worst]:.0f} % of its tolerance "
            f"(allowed {100 * allowed:.0f} %). Expose the scan longer, or repeat it and "
            "average, then validate again."
        )
    return check


def white_from_patch(
    chart: PatchStatistics, reference: ReferenceChart, bin_edges_nm: NDArray[np.float64]
) -> NDArray[np.float64]:
    """The signal of a perfect white from the chart's white patch, (B,).

    Examples
    --------
    >>> from sassi_bench.validate.reference import reference_chart
    >>> ref = reference_chart()
    >>> edges = np.array([450.0, 550.0, 650.0])
    >>> stats = PatchStatistics(np.tile(ref.bin_average(edges), 1), np.zeros((24, 2)),
    ...                         np.ones(24, dtype=np.intp))
    >>> white_from_patch(stats, ref, edges).round(6).tolist()
    [1.0, 1.0]
    """
    white_ref = reference.bin_average(bin_edges_nm)[WHITE_PATCH]
    return chart.mean[WHITE_PATCH] / white_ref


def standard_error(stats: PatchStatistics) -> NDArray[np.float64]:
    """Standard error of every patch mean, (24, B): the pixel spread over sqrt(pixels).

    Examples
    --------
    >>> s = PatchStatistics(np.ones((24, 2)), np.full((24, 2), 0.2), np.full(24, 4))
    >>> standard_error(s)[0].tolist()
    [0.1, 0.1]
    """
    return stats.std / np.sqrt(np.maximum(stats.count, 1))[:, None]


def white_from_diffuser(white: PatchStatistics, reflectance: float) -> NDArray[np.float64]:
    """The signal of a perfect white at every patch position from a diffuser scan, (24, B).

    Each patch is divided by the diffuser measured at the same place, so uneven light
    across the chart cancels.

    Examples
    --------
    >>> s = PatchStatistics(np.full((24, 2), 0.49), np.zeros((24, 2)), np.ones(24, int))
    >>> white_from_diffuser(s, 0.98)[0].tolist()
    [0.5, 0.5]
    """
    if np.any(white.count == 0):
        missing = ", ".join(str(i + 1) for i in np.flatnonzero(white.count == 0))
        raise ProcedureError(
            step_error(
                "Macbeth white reference",
                f"the diffuser scan has no measured pixels where patch(es) {missing} lie",
                "scan the diffuser over the whole chart area, or use the chart's white patch",
            )
        )
    return white.mean / float(reflectance)
