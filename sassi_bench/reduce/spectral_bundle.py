"""The publish stage of the spectral calibration: report figures and the bundle.

:func:`render_figures` renders the plots into the result; :func:`publish_spectral`
writes the models, the quality section (checks named ``spectral.<check>``, residuals,
laser lines, notes), the procedure, the input sessions and the figures as a new
calibration bundle.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench.bundle import publish
from sassi_bench.bundle.derive import stage_checks
from sassi_bench.calibrate.stated_lines import StatedLine
from sassi_bench.reduce.lamps import LampAnchoring
from sassi_bench.reduce.spectral import SpectralCalibration, spectral_notes

__all__ = ["anchoring_section", "publish_spectral", "quality_section", "render_figures"]


def render_figures(result: SpectralCalibration) -> None:
    """Render the calibration's plots into ``result.figures`` (PNG bytes by name).

    Parameters
    ----------
    result
        An analysed spectral calibration; its ``figures`` are replaced.

    Examples
    --------
    Not run here (it needs captured sessions)::

        render_figures(result)
        sorted(result.figures)
        # ['blur', 'dispersion', 'residual_maps']
    """
    from sassi_bench.plots.png import figure_png
    from sassi_bench.plots.spectral import spectral_figures

    result.figures = {name: figure_png(fig) for name, fig in spectral_figures(result).items()}


def quality_section(result: SpectralCalibration) -> dict[str, Any]:
    """The ``quality`` section of the bundle manifest (checks named ``spectral.<check>``).

    Parameters
    ----------
    result
        An analysed spectral calibration.

    Returns
    -------
    dict
        ``checks``, ``residuals``, ``leave_one_out``, ``laser_lines`` and ``notes``,
        JSON-compatible; with lamp anchoring, ``laser_lines`` holds each laser's
        measured line, ``lamps`` each lamp's fit and ``lamp_frames`` what the lamp step
        took and why (frames per lamp, the uncertainty reached, its outcome and batches);
        with a field blur, ``blur_frames`` what the blur step took and why.

    Examples
    --------
    Not run here (it needs captured sessions)::

        sorted(quality_section(result))
        # ['checks', 'laser_lines', 'leave_one_out', 'notes', 'residuals']
    """
    disp = result.dispersion
    section = {
        "checks": stage_checks("spectral", result.checks),
        "residuals": {
            "correspondence_rms_px": {
                f"{d.wavelength_nm:g}": d.residual_rms_px for d in result.lasers
            },
            "valid_fraction": {f"{d.wavelength_nm:g}": d.valid_fraction for d in result.lasers},
            "decode_counts": {f"{d.wavelength_nm:g}": d.counts for d in result.lasers},
            "dispersion_residual_px": {f"{k:g}": v for k, v in disp.residual_px.items()},
            "position_sigma_px": disp.position_sigma_px,
            "position_sigma_nm": disp.position_sigma_nm,
            "position_sigma_rms_nm": disp.position_sigma_rms_nm,
            "position_sigma_rms_px": disp.position_sigma_rms_px,
            "line_sigma_nm": disp.line_sigma_nm,
            "line_sigma_max_nm": disp.line_sigma_max_nm,
            "form_sigma_rms_nm": disp.form_sigma_rms_nm,
            "blur_measured_sigma_px": dict(
                zip(
                    [f"{x:g}" for x in result.blur.wavelengths_nm],
                    result.blur.measured_sigma_px.tolist(),
                    strict=True,
                )
            ),
        },
        "leave_one_out": {f"{k:g}": v for k, v in disp.leave_one_out.items()},
        "laser_lines": {
            f"{label:g}": {
                "label_nm": line.label_nm,
                "estimated_nm": line.estimated_nm if np.isfinite(line.estimated_nm) else None,
                "fitted_nm": disp.wavelengths_nm.get(label, label),
                "from_lines_nm": list(line.from_lines),
                "off_label": line.off_label,
                # How far the estimate may be from the label on a right bundle (the
                # laser_line check's tolerance) and the part the others' accuracy adds.
                "propagated_nm": line.propagated_nm,
                "allowed_nm": line.allowed_nm(
                    float(result.procedure["tolerances"].get("laser_line_nm", 0.5))
                ),
                **_stated_line(result.stated_lines.get(label)),
            }
            for label, line in result.laser_lines.items()
        },
        "notes": spectral_notes(result),
    }
    if result.anchoring is not None:
        section.update(anchoring_section(result.anchoring, disp))
    if getattr(result, "design_comparison", None) is not None:
        section["design_comparison"] = result.design_comparison.to_json()
    if result.blur_record is not None:
        section["blur_frames"] = result.blur_record.to_json()
    if getattr(result, "lamp_field_record", None) is not None:
        section["lamp_field_frames"] = result.lamp_field_record.to_json()
    return section


def _stated_line(line: StatedLine | None) -> dict[str, float]:
    """A line stated to a test sheet's accuracy: the sheet's 1-sigma, and the fitted
    wavelength's 1-sigma and the model form's part of it (nothing for other lines)."""
    if line is None:
        return {}
    return {
        "stated_sigma_nm": line.stated_sigma_nm,
        "fitted_sigma_nm": line.sigma_nm,
        "form_nm": line.form_nm,
    }


def anchoring_section(anchoring: LampAnchoring, dispersion) -> dict[str, Any]:
    """The lamp-anchored parts of the quality section: every laser's measured line
    (``laser_lines``), every lamp's fit (``lamps``) and, when the lamp step measured until
    confident, what it took and why (``lamp_frames``).

    Parameters
    ----------
    anchoring
        The calibration's lamp anchoring.
    dispersion
        The final dispersion fit (the wavelengths it used).

    Returns
    -------
    dict
        ``laser_lines`` and ``lamps``, JSON-compatible.

    Examples
    --------
    Not run here (it needs captured sessions)::

        sorted(anchoring_section(result.anchoring, result.dispersion))
        # ['lamps', 'laser_lines']
    """
    fit = anchoring.fit
    free = anchoring.measured or fit
    lines = {
        f"{label:g}": {
            "label_nm": float(label),
            "measured_nm": float(measured),
            "sigma_nm": float(sigma),
            "fitted_nm": dispersion.wavelengths_nm.get(float(label), float(measured)),
            "method": anchoring.method(label),
            "anchors": sorted(fit.lamps),
            # How far the measurement moves with one more power in the column model.
            **(
                {"form_shift_nm": anchoring.form_shift_nm[float(label)]}
                if float(label) in anchoring.form_shift_nm
                else {}
            ),
        }
        for label, measured, sigma in zip(
            free.labels_nm, free.wavelengths_nm, free.sigma_nm, strict=True
        )
    }
    residuals = anchoring.line_residuals_nm()
    lamps = {}
    for data in anchoring.streaks:
        table = anchoring.tables[data.name]
        lamp = fit.lamps[data.name]
        light = table.light
        lamps[data.name] = {
            "light": light,
            "table_sha256": table.sha256,
            "source": table.source,
            "exposure_s": anchoring.exposures_s.get(light),
            "frames": anchoring.frames,
            "pinholes": data.profiles.count,
            "chi2": lamp.chi2,
            "lines": [
                {
                    "wavelength_nm": float(lam),
                    "amplitude": float(amplitude),
                    "residual_nm": residuals[data.name].get(float(lam), (None, None))[0],
                    "sigma_nm": residuals[data.name].get(float(lam), (None, None))[1],
                }
                for lam, amplitude in zip(data.lines_nm, lamp.amplitudes, strict=True)
            ],
        }
    section = {"laser_lines": lines, "lamps": lamps}
    if anchoring.record is not None:
        section["lamp_frames"] = anchoring.record.to_json()
    return section


def publish_spectral(
    result: SpectralCalibration,
    *,
    data: str | os.PathLike[str] | None = None,
    allow_failed: bool = False,
) -> Path:
    """Publish the spectral calibration as a bundle (plots go under ``report/``).

    Parameters
    ----------
    result
        An analysed spectral calibration, with its figures rendered
        (:func:`render_figures`) if the bundle should carry them.
    data
        Data root the bundle is written under.
    allow_failed
        Publish even when a quality check failed (the bundle records the failure).

    Returns
    -------
    Path
        The new bundle version's folder.

    Examples
    --------
    Not run here (it needs captured sessions)::

        publish_spectral(result, data="calib_data")
        # PosixPath('calib_data/sim/v0001')
    """
    return publish(
        result.models(),
        rig=result.rig_description,
        quality=quality_section(result),
        procedure={k: v for k, v in result.procedure.items() if k != "source"},
        inputs=[{"id": s.id, "sha256": s.sha256(), "kind": "session"} for s in result.sessions],
        reports={f"{name}.png": png for name, png in result.figures.items()},
        allow_failed=allow_failed,
        data=data,
    )
