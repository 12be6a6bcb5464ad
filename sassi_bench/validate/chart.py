"""The Macbeth validation of assembled scans: find the patches, take the white reference,
compare with the reference chart (no devices; :func:`sassi_bench.workflows.macbeth.run_macbeth`
captures the scans on a rig and calls :func:`validate_scans`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.spectra.forward import StreakForwardModel
from sassi_bench.spectra.scan import ScanCube
from sassi_bench.spectra.scan_deblur import labelled_mean_spectra
from sassi_bench.validate.colorimetry import cube_to_srgb, reflectance_to_xyz
from sassi_bench.validate.locate import ChartGrid, LocateError, detect_chart, grid_from_corners
from sassi_bench.validate.macbeth import (
    MacbethResult,
    PatchStatistics,
    patch_statistics,
    standard_error,
    validate_macbeth,
    white_from_diffuser,
    white_from_patch,
)
from sassi_bench.validate.reference import PATCH_COUNT, WHITE_PATCH, ReferenceChart, reference_chart

__all__ = ["locate_chart", "reference_rgb", "starting_corners", "validate_scans"]


def reference_rgb(reference: ReferenceChart) -> NDArray[np.float64]:
    """Linear sRGB of the reference patches under D65, (24, 3): the detector's colour cue.

    Examples
    --------
    >>> from sassi_bench.validate.reference import reference_chart
    >>> reference_rgb(reference_chart()).shape
    (24, 3)
    """
    import colour

    xyz = reflectance_to_xyz(reference.wavelengths_nm, reference.reflectance)
    return np.asarray(colour.XYZ_to_sRGB(xyz, apply_cctf_encoding=False), dtype=np.float64)


def _scan_picture(scan: ScanCube) -> NDArray[np.float32]:
    # Flagged pixels keep their values: a saturated streak still shows where a patch is.
    return cube_to_srgb(scan.wavelengths_nm, scan.cube)


def locate_chart(
    scan: ScanCube,
    reference: ReferenceChart,
    *,
    corners: Sequence[Sequence[float]] | None = None,
    picture: NDArray[Any] | None = None,
) -> ChartGrid:
    """Where the patches are: from four corners, else by detection on a picture.

    Parameters
    ----------
    scan
        The chart scan; its RGB rendering is the default picture.
    reference
        Reference reflectances (the detector's orientation cue).
    corners
        SLM ``(u, v)`` centres of patches 1, 6, 24 and 19; skips detection.
    picture
        (H_slm, W_slm, 3) picture on the full SLM grid (e.g.
        :func:`sassi_bench.workflows.macbeth.guide_picture`)
        instead of the cube's rendering.
    """
    if corners is not None:
        return grid_from_corners(corners)
    if picture is None:
        rgb = cube_to_srgb(scan.wavelengths_nm, scan.cube, usable=scan.quality == 0)
        grid = detect_chart(rgb, reference_rgb(reference))
        # Detected in ROI pixels: move the map to SLM coordinates.
        shift = np.array([[1, 0, scan.origin[1]], [0, 1, scan.origin[0]], [0, 0, 1]], float)
        return ChartGrid(shift @ grid.homography, grid.method, grid.detected)
    return detect_chart(np.asarray(picture), reference_rgb(reference))


def starting_corners(
    scan: ScanCube, reference: ReferenceChart, slm_shape: tuple[int, int]
) -> tuple[NDArray[np.float64], str]:
    """Centres of patches 1, 6, 24 and 19 to start a manual placement from.

    The detector's result when it finds the chart, else a box over the middle of the
    SLM; with a sentence saying which.

    Examples
    --------
    Not run here (it needs a scan or a procedure's result)::

        corners, note = starting_corners(scan, reference, (400, 640))
    """
    try:
        found = locate_chart(scan, reference)
    except LocateError as exc:
        h, w = slm_shape
        box = np.array(
            [[0.2 * w, 0.2 * h], [0.8 * w, 0.2 * h], [0.8 * w, 0.8 * h], [0.2 * w, 0.8 * h]]
        )
        return box, f"the detector did not find the chart ({exc}); place the corners by hand"
    return found.centres()[[0, 5, 23, 18]], f"the detector found {found.detected} patches"


def _deblurred_means(
    stats: PatchStatistics, scan: ScanCube, model: StreakForwardModel, labels: NDArray[np.intp]
) -> PatchStatistics:
    """Patch statistics whose means are deblurred after averaging, when the scan kept its
    column sums: noise averages out of a patch mean, the per-pixel deblur's smoothing bias
    does not (on the sim rig this halves the red patch's RMSE). The spread stays the
    per-pixel cube's (the noise floor)."""
    if scan.column_sums is None:
        return stats
    good = (scan.quality == 0) & np.all(np.isfinite(scan.cube), axis=-1)
    means = labelled_mean_spectra(scan, model, good, labels, PATCH_COUNT)
    return replace(stats, mean=np.where(np.isfinite(means), means, stats.mean))


def validate_scans(
    chart: ScanCube,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    white: ScanCube | None = None,
    corners: Sequence[Sequence[float]] | None = None,
    picture: NDArray[Any] | None = None,
    settings: Mapping[str, Any] | None = None,
) -> MacbethResult:
    """Validate a bundle from an assembled chart scan (and a diffuser scan).

    Parameters
    ----------
    chart
        Pinhole scan of the chart, assembled with ``bundle``.
    bundle
        The bundle under test.
    procedure
        The ``macbeth_validation`` procedure.
    white
        Diffuser scan, in the same units, when ``white_reference.source`` is ``diffuser``.
    corners, picture
        See :func:`locate_chart`.
    settings
        Provenance added to the report.
    """
    source = procedure["white_reference"]["source"]
    if source == "diffuser" and white is None:
        raise ProcedureError(
            step_error(
                "Macbeth white reference",
                "the procedure asks for a white diffuser scan and none was given",
                "scan the diffuser, or set white_reference.source to 'patch'",
            )
        )
    for scan, what in ((chart, "chart"), (white, "diffuser")):
        if scan is not None and not np.allclose(scan.wavelengths_nm, bundle.wavelengths):
            raise ProcedureError(
                step_error(
                    "Macbeth validation",
                    f"the {what} scan was assembled with other wavelength bins than bundle "
                    f"{bundle.rig_name}/{bundle.version}",
                    "assemble both scans with the bundle under test",
                )
            )
    reference = reference_chart(procedure["reference"]["data"])
    if procedure["localisation"]["method"] == "corners" and corners is None:
        raise ProcedureError(
            step_error(
                "Macbeth patch localisation",
                "the procedure asks for manual corners and none were given",
                "give --corners u1 v1 u6 v6 u24 v24 u19 v19 (centres of patches 1, 6, 24, 19)",
            )
        )
    grid = locate_chart(chart, reference, corners=corners, picture=picture)
    if picture is None:
        shown = _scan_picture(chart)
        shown_origin = chart.origin
    else:
        shown, shown_origin = np.asarray(picture, dtype=np.float32), (0, 0)
    interior = float(procedure["localisation"]["interior"])
    labels = grid.labels(chart.quality.shape, chart.origin, interior)
    model = StreakForwardModel.from_bundle(bundle)
    stats = _deblurred_means(
        patch_statistics(chart.cube, chart.quality, labels), chart, model, labels
    )
    if source == "diffuser":
        assert white is not None
        white_labels = grid.labels(white.quality.shape, white.origin, interior)
        white_stats = _deblurred_means(
            patch_statistics(white.cube, white.quality, white_labels), white, model, white_labels
        )
        diffuser = float(procedure["white_reference"]["diffuser_reflectance"])
        white_signal = white_from_diffuser(white_stats, diffuser)
        white_error = standard_error(white_stats) / diffuser
    else:
        white_signal = white_from_patch(stats, reference, bundle.bin_edges)
        white_error = white_signal * standard_error(stats)[WHITE_PATCH] / stats.mean[WHITE_PATCH]
    info = {
        "bundle": f"{bundle.rig_name}/{bundle.version}",
        "bundle_passed": bundle.passed,
        "reference": reference.name,
        "white_reference": source,
        "localisation": grid.method,
        "patches_detected": grid.detected,
        "interior": interior,
        "procedure": procedure.get("source", ""),
        "patch_spectra": "column sums averaged over each patch, then deblurred once"
        if chart.column_sums is not None
        else "per-pixel deblurred spectra averaged over each patch",
        **dict(settings or {}),
    }
    result = validate_macbeth(
        stats,
        white_signal,
        reference,
        bundle.bin_edges,
        bundle.wavelengths,
        procedure,
        grid,
        settings=info,
        white_error=white_error,
    )
    result.picture, result.picture_origin = shown, tuple(shown_origin)
    return result
