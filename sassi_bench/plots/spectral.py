"""Figures of the spectral calibration: residual maps, dispersion curve, blur curve."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.stats import binned_statistic_2d

__all__ = ["blur_figure", "dispersion_figure", "residual_maps_figure", "spectral_figures"]


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


def residual_maps_figure(lasers, slm_shape: tuple[int, int]):
    """Per laser: RMS distance (camera px) of the decoded correspondences from the smooth
    map, binned over the SLM field.

    Parameters
    ----------
    lasers
        Every laser's :class:`~sassi_bench.workflows.spectral_decode.LaserDecode`.
    slm_shape
        SLM (height, width).

    Returns
    -------
    matplotlib.figure.Figure
        One map per laser on a 16 x 24 grid over the SLM, all on one colour scale.

    Examples
    --------
    >>> fig = residual_maps_figure(result.lasers, bundle.slm_shape)  # doctest: +SKIP
    """
    n = len(lasers)
    fig = _figure(figsize=(3.2 * n, 2.9), layout="constrained")
    axes = fig.subplots(1, n, squeeze=False)[0]
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
        ax.set_title(f"{d.wavelength_nm:g} nm: {d.residual_rms_px:.3f} px rms", fontsize=9)
        ax.set_xlabel("SLM u (px)")
        ax.set_ylabel("SLM v (px)")
    fig.colorbar(image, ax=axes, shrink=0.8, label="residual RMS (camera px)")
    fig.suptitle("Correspondence residuals about each laser's smooth map", fontsize=10)
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
        Every laser's :class:`~sassi_bench.workflows.spectral_decode.LaserDecode`.
    slm_shape
        SLM (height, width).

    Returns
    -------
    matplotlib.figure.Figure
        The dispersion curves with the laser points, and bin width against bin centre.

    Examples
    --------
    >>> fig = dispersion_figure(result.dispersion, result.lasers, (400, 640))  # doctest: +SKIP
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
    """Measured line-spread widths at the laser lines and the quadratic fit.

    Parameters
    ----------
    blur
        The :class:`~sassi_bench.calibrate.blur.BlurFit`.

    Returns
    -------
    matplotlib.figure.Figure
        Spot sigma against wavelength: the fit and the measured points.

    Examples
    --------
    >>> fig = blur_figure(result.blur)  # doctest: +SKIP
    """
    fig = _figure(figsize=(4.8, 3.4), layout="constrained")
    ax = fig.subplots()
    lam = np.linspace(400, 700, 200)
    ax.plot(lam, blur.model.sigma(lam), label="quadratic fit")
    ax.plot(blur.wavelengths_nm, blur.measured_sigma_px, "o", label="measured (median of spots)")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("spot sigma (camera px)")
    ax.set_title(f"Blur: fit residual {blur.rms_px:.3f} px rms", fontsize=10)
    ax.legend(fontsize=8)
    return fig


def spectral_figures(result: Any) -> dict[str, Any]:
    """The report figures of a spectral calibration.

    Parameters
    ----------
    result
        A :class:`~sassi_bench.workflows.spectral_analysis.SpectralCalibration`.

    Returns
    -------
    dict
        ``"residual_maps"``, ``"dispersion"`` and ``"blur"`` -> figure.

    Examples
    --------
    >>> figures = spectral_figures(result)  # doctest: +SKIP
    """
    shape = result.lasers[0].laser_map.x.slm_shape
    return {
        "residual_maps": residual_maps_figure(result.lasers, shape),
        "dispersion": dispersion_figure(result.dispersion, result.lasers, shape),
        "blur": blur_figure(result.blur),
    }
