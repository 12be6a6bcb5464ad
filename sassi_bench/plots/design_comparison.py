"""The calibration report's figure of a design rig: as designed against as built.

Over the SLM field: how far the measured positions lie from the design's (colour: RMS
over the wavelengths; arrows: the mean shift, magnified) and how much wider the measured
spot is along and across the streak; against wavelength: the mean shift in x and y (a
rolled prism tilts the streaks: y changes with wavelength); and the diagnosis, every
candidate misalignment with the share of the difference it explains and its amount. The
verdict is the title.
"""

from __future__ import annotations

import textwrap
from typing import Any

import numpy as np
from matplotlib.figure import Figure

__all__ = ["design_comparison_figure"]


def _field(values: np.ndarray, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per-point values on the comparison grid as (rows, columns) images with their nodes."""
    columns, rows = np.unique(u), np.unique(v)
    image = np.full((rows.size, columns.size), np.nan)
    image[np.searchsorted(rows, v), np.searchsorted(columns, u)] = values
    return columns, rows, image


def design_comparison_figure(comparison: Any) -> Figure:
    """Difference maps of the measured bundle against the described design, and the
    diagnosis.

    Parameters
    ----------
    comparison
        A :class:`~sassi_bench.reduce.design_comparison.DesignComparison`.

    Returns
    -------
    matplotlib.figure.Figure
        Three maps over the SLM, the shift against wavelength and the candidates' fits.

    Examples
    --------
    Not run here (it needs the ray tracer)::

        fig = design_comparison_figure(result.design_comparison)
    """
    design, measured = comparison.design, comparison.measured
    u, v, lam = design.u, design.v, design.wavelengths_nm
    dx, dy = measured.x - design.x, measured.y - design.y
    fig = Figure(figsize=(12, 7.4), layout="constrained")
    top, bottom = fig.subfigures(2, 1, height_ratios=[1.0, 0.9])
    maps = top.subplots(1, 3)
    distance = np.sqrt(np.mean(dx**2 + dy**2, axis=1))
    columns, rows, image = _field(distance, u, v)
    ax = maps[0]
    mesh = ax.pcolormesh(columns, rows, image, cmap="magma", vmin=0.0, shading="nearest")
    top.colorbar(mesh, ax=ax, shrink=0.85, label="RMS over wavelength (camera px)")
    mean_x, mean_y = dx.mean(axis=1), dy.mean(axis=1)
    ax.quiver(u, v, mean_x, mean_y, color="tab:cyan", angles="xy", pivot="mid")
    ax.set_title("position: measured - design\n(arrows: mean shift)", fontsize=10)
    widths = comparison.width_difference_px.mean(axis=2)
    bound = max(float(np.nanmax(np.abs(widths))), 0.02)
    for ax, values, name in zip(maps[1:], widths, ("along", "across"), strict=True):
        columns, rows, image = _field(values, u, v)
        mesh = ax.pcolormesh(
            columns, rows, image, cmap="RdBu_r", vmin=-bound, vmax=bound, shading="nearest"
        )
        top.colorbar(mesh, ax=ax, shrink=0.85, label="mean over wavelength (camera px)")
        ax.set_title(f"spot sigma {name} the streak:\nmeasured - design", fontsize=10)
    for ax in maps:
        ax.set_xlabel("SLM u (px)")
        ax.set_ylabel("SLM v (px)")
        ax.invert_yaxis()
        ax.set_aspect("equal")
    ax_lam, ax_fit = bottom.subplots(1, 2, width_ratios=[1.0, 1.4])
    for values, name in ((dx, "x (along the streak)"), (dy, "y (across)")):
        mean = values.mean(axis=0)
        line = ax_lam.plot(lam, mean, "o-", label=f"mean {name}")[0]
        ax_lam.fill_between(
            lam, values.min(axis=0), values.max(axis=0), color=line.get_color(), alpha=0.2, lw=0
        )
    ax_lam.axhline(0.0, color="k", lw=0.5)
    ax_lam.set_xlabel("wavelength (nm)")
    ax_lam.set_ylabel("measured - design (camera px)")
    ax_lam.set_title("position shift against wavelength (band: over the field)", fontsize=10)
    ax_lam.legend(fontsize=8)
    diagnoses = comparison.diagnoses
    if diagnoses:
        shares = [100 * max(d.explained, 0.0) for d in diagnoses][::-1]
        labels = [d.candidate.describe(d.amount) for d in diagnoses][::-1]
        bars = ax_fit.barh(range(len(shares)), shares, color="tab:blue")
        for bar in bars[len(bars) - len(comparison.named) :]:
            bar.set_color("tab:red")  # the named misalignment, and those it cannot be told from
        ax_fit.set_yticks(range(len(shares)), labels, fontsize=8)
        ax_fit.set_xlim(0, 100)
        ax_fit.set_xlabel("share of the difference it explains (%)")
        ax_fit.set_title("Each candidate misalignment fitted alone", fontsize=10)
    else:
        ax_fit.set_axis_off()
        ax_fit.text(
            0.5,
            0.5,
            "No diagnosis needed:\nthe bench matches its design",
            ha="center",
            va="center",
            fontsize=11,
        )
    colour = "tab:green" if comparison.matches else "tab:red"
    fig.suptitle(
        "As designed against as built\n" + textwrap.fill(comparison.verdict, 130),
        fontsize=11,
        color=colour,
    )
    return fig
