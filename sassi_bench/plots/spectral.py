"""Figures of the spectral calibration: residual maps, dispersion curve, blur curve, and
on a rig with wavelength lamps the lamp spectra against their line lists."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.stats import binned_statistic_2d

from sassi_bench.plots.design_comparison import design_comparison_figure

__all__ = [
    "blur_figure",
    "dispersion_figure",
    "lamp_spectrum_figure",
    "residual_maps_figure",
    "spectral_figures",
]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


#: Residual maps per row: a notebook shows a figure at about 10 inches wide, so more
#: maps side by side would shrink their labels below reading size.
MAPS_PER_ROW = 3


def residual_maps_figure(lasers, slm_shape: tuple[int, int]):
    """Per laser: RMS distance (camera px) of the decoded correspondences from the smooth
    map, binned over the SLM field (three maps per row, so the labels stay readable).

    Parameters
    ----------
    lasers
        Every laser's :class:`~sassi_bench.reduce.sweeps.LaserDecode`.
    slm_shape
        SLM (height, width).

    Returns
    -------
    matplotlib.figure.Figure
        One map per laser on a 16 x 24 grid over the SLM, all on one colour scale,
        :data:`MAPS_PER_ROW` per row.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig = residual_maps_figure(result.lasers, bundle.slm_shape)
    """
    n = len(lasers)
    columns = min(n, MAPS_PER_ROW)
    rows = -(-n // columns)
    fig = _figure(figsize=(3.4 * columns + 0.8, 2.8 * rows + 0.5), layout="constrained")
    grid = fig.subplots(rows, columns, squeeze=False)
    axes = grid.ravel()[:n]
    for spare in grid.ravel()[n:]:
        spare.set_visible(False)
    h, w = slm_shape
    distances = [
        np.hypot(
            d.laser_map.x(d.slm_u, d.slm_v) - d.camera_x,
            d.laser_map.y(d.slm_u, d.slm_v) - d.camera_y,
        )
        for d in lasers
    ]
    vmax = max(float(np.percentile(dist, 99)) for dist in distances)
    for ax, d, dist in zip(axes, lasers, distances, strict=True):
        stat, _, _, _ = binned_statistic_2d(
            d.slm_v, d.slm_u, dist**2, "mean", bins=[16, 24], range=[[0, h], [0, w]]
        )
        image = ax.imshow(np.sqrt(stat), extent=(0, w, h, 0), vmin=0, vmax=vmax, cmap="magma")
        ax.set_title(f"{d.wavelength_nm:g} nm: {d.residual_rms_px:.3f} px rms", fontsize=11)
        ax.set_xlabel("SLM u (px)", fontsize=10)
        ax.set_ylabel("SLM v (px)", fontsize=10)
        ax.tick_params(labelsize=9)
    bar = fig.colorbar(image, ax=grid.ravel().tolist(), shrink=0.8)
    bar.set_label("residual RMS (camera px)", fontsize=10)
    bar.ax.tick_params(labelsize=9)
    fig.suptitle("Correspondence residuals about each laser's smooth map", fontsize=12)
    return fig


def dispersion_figure(dispersion, lasers, slm_shape: tuple[int, int]):
    """Streak position versus wavelength at five field points with the laser points, and
    the wavelength resolution of the bins.

    Parameters
    ----------
    dispersion
        The :class:`~sassi_bench.calibrate.dispersion.DispersionFit`: its model, bins and
        leave-one-out errors.
    lasers
        Every laser's :class:`~sassi_bench.reduce.sweeps.LaserDecode`.
    slm_shape
        SLM (height, width).

    Returns
    -------
    matplotlib.figure.Figure
        The dispersion curves with the laser points, and bin width against bin centre.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig = dispersion_figure(result.dispersion, result.lasers, (400, 640))
    """
    fig = _figure(figsize=(9, 3.6), layout="constrained")
    ax, ax_res = fig.subplots(1, 2)
    h, w = slm_shape
    points = {"centre": ((w - 1) / 2, (h - 1) / 2), "top left": (0, 0), "top right": (w - 1, 0),
              "bottom left": (0, h - 1), "bottom right": (w - 1, h - 1)}  # fmt: skip
    lam = np.linspace(395, 705, 200)
    model = dispersion.model
    for name, (u, v) in points.items():
        x, _ = model.evaluate(u, v, lam)
        x0, _ = model.evaluate(u, v, 550.0)
        line = ax.plot(lam, x - x0, lw=1, label=name)[0]
        measured = [d.laser_map.x(u, v) - x0 for d in lasers]
        ax.plot([d.wavelength_nm for d in lasers], measured, "o", ms=4, color=line.get_color())
    loo = dispersion.leave_one_out
    if loo:
        text = "\n".join(f"{k:g} nm: {v['rms_nm']:.3f} nm" for k, v in loo.items())
        ax.text(0.02, 0.97, "leave-one-out\n" + text, transform=ax.transAxes, va="top", fontsize=7)
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("camera x - x(550 nm) (px)")
    ax.set_title("Dispersion: model (lines) and laser maps (dots)", fontsize=10)
    ax.legend(fontsize=7, loc="lower right")
    bins = dispersion.bins
    ax_res.step(bins.centres_nm, bins.resolution_nm, where="mid")
    ax_res.set_xlabel("bin centre (nm)")
    ax_res.set_ylabel("bin width (nm)")
    ax_res.set_title(f"{bins.count} wavelength bins, one per camera column", fontsize=10)
    return fig


def blur_figure(blur):
    """Measured line-spread widths at the laser lines and the fit, as a camera measures
    them.

    Parameters
    ----------
    blur
        The :class:`~sassi_bench.calibrate.blur.BlurFit`.

    Returns
    -------
    matplotlib.figure.Figure
        Spot sigma against wavelength: the fit, its stated error as a band, and the
        measured points.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig = blur_figure(result.blur)
    """
    fig = _figure(figsize=(4.8, 3.4), layout="constrained")
    ax = fig.subplots()
    lam = np.linspace(400, 700, 200)
    label = {"psf_quadratic": "fit: PSF quadratic, pixel boxes added"}.get(
        blur.model.kind, "quadratic fit"
    )
    # What the camera measures (the camera pixel's box too), the measured points' scale.
    sigma = blur.camera_width_px(lam)
    ax.plot(lam, sigma, label=label)
    title = f"Blur: fit residual {blur.rms_px:.3f} px rms"
    error = blur.model.relative_error
    if error is not None:
        ax.fill_between(lam, sigma * (1 - error), sigma * (1 + error), alpha=0.25, lw=0,
                        label="its error where no laser is (leave one out)")  # fmt: skip
        title += f", {100 * error:.1f} % between lasers"
    ax.plot(blur.wavelengths_nm, blur.measured_sigma_px, "o", label="measured (median of spots)")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("spot sigma (camera px)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    return fig


def _streak_wavelengths(model, profiles) -> np.ndarray:
    """The wavelength of every profile sample under ``model`` (P, W)."""
    lam = np.linspace(370.0, 740.0, 741)
    x, _ = model.evaluate(profiles.u[:, None], profiles.v[:, None], lam[None, :])
    # Columns increase with wavelength: interpolate each pinhole's inverse (a plot, P ~ 100).
    return np.stack(
        [np.interp(cols, xs, lam) for cols, xs in zip(profiles.columns, x, strict=True)]
    )


def lamp_spectrum_figure(anchoring, model):
    """Per lamp: every pinhole's streak on the fitted wavelength axis against the lamp's
    line list, and the fitted line amplitudes against the table's intensities.

    Parameters
    ----------
    anchoring
        A :class:`~sassi_bench.reduce.lamps.LampAnchoring`.
    model
        The calibration's dispersion model (it puts the streaks on a wavelength axis).

    Returns
    -------
    matplotlib.figure.Figure
        Two panels per lamp.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig = lamp_spectrum_figure(result.anchoring, result.dispersion.model)
    """
    streaks = anchoring.streaks
    fig = _figure(figsize=(9.5, 3.9 * len(streaks)), layout="constrained")
    axes = fig.subplots(2 * len(streaks), 1, squeeze=False, height_ratios=[2, 1] * len(streaks))
    for i, data in enumerate(streaks):
        ax, ax_lines = axes[2 * i, 0], axes[2 * i + 1, 0]
        lamp = anchoring.fit.lamps[data.name]
        table = anchoring.tables[data.name]
        prof = data.profiles
        wl = _streak_wavelengths(model, prof)
        gain = np.where(lamp.gains > 0, lamp.gains, np.nan)[:, None]
        signal = (prof.profile - lamp.backgrounds[:, None]) / gain
        top = float(np.nanpercentile(signal, 99.9))
        ax.plot(wl.ravel(), signal.ravel() / top, ",", color="C0", alpha=0.4)
        ax.plot([], [], ".", color="C0", label=f"{prof.count} pinholes, each over its gain")
        for lam in table.wavelengths_nm:
            ax.axvline(lam, color="0.6", lw=0.6, zorder=0)
        ax.axvline(np.nan, color="0.6", lw=0.6, label=f"{data.name} lines (table)")
        ax.set_xlim(395, 712)
        ax.set_ylim(-0.05, 1.1)
        ax.set_ylabel("signal / gain (rel.)")
        residuals = np.abs(lamp.line_residual_nm[np.isfinite(lamp.line_residual_nm)])
        worst = f"; worst line residual {residuals.max():.3f} nm" if residuals.size else ""
        ax.set_title(
            f"{data.name} lamp on the calibrated wavelength axis (reduced chi-square "
            f"{lamp.chi2:.1f}{worst})",
            fontsize=10,
        )
        ax.legend(fontsize=7, loc="upper left")
        fitted = lamp.amplitudes / lamp.amplitudes.max()
        seen = "fitted amplitude (as the camera sees it)"
        ax_lines.vlines(data.lines_nm, 0, fitted, color="C1", lw=1.5, label=seen)
        listed = data.start_intensity / data.start_intensity.max()
        ax_lines.vlines(data.lines_nm, 0, -listed, color="0.4", lw=1.5, label="table intensity")
        ax_lines.axhline(0, color="k", lw=0.5)
        ax_lines.set_xlim(395, 712)
        ax_lines.set_ylim(-1.1, 1.1)
        ax_lines.set_xlabel("wavelength (nm)")
        ax_lines.set_ylabel("relative")
        ax_lines.legend(fontsize=7, loc="upper left", ncols=2)
    return fig


def spectral_figures(result: Any) -> dict[str, Any]:
    """The report figures of a spectral calibration (with the lamp spectra when lamps
    anchored it).

    Parameters
    ----------
    result
        A :class:`~sassi_bench.reduce.spectral.SpectralCalibration`.

    Returns
    -------
    dict
        ``"residual_maps"``, ``"dispersion"``, ``"blur"``, with lamp anchoring
        ``"lamp_spectrum"`` and on a design rig ``"design_comparison"`` -> figure.

    Examples
    --------
    Not run here (it needs a procedure's result)::

        figures = spectral_figures(result)
    """
    shape = result.lasers[0].laser_map.x.slm_shape
    figures = {
        "residual_maps": residual_maps_figure(result.lasers, shape),
        "dispersion": dispersion_figure(result.dispersion, result.lasers, shape),
        "blur": blur_figure(result.blur),
    }
    if getattr(result, "anchoring", None) is not None:
        figures["lamp_spectrum"] = lamp_spectrum_figure(result.anchoring, result.dispersion.model)
    if getattr(result, "design_comparison", None) is not None:
        figures["design_comparison"] = design_comparison_figure(result.design_comparison)
    return figures
