"""Figures and the HTML page of the calibration health checks' history.

:func:`trend_figure` plots each check's largest streak shift, mean shift and implied
wavelength error against time, with the tolerances drawn in, markers coloured by verdict
and a dashed line where the bundle changes; :func:`write_trend_html` puts it with a
table of the checks on one self-contained page.
"""

from __future__ import annotations

import html
import os
from collections.abc import Mapping, Sequence
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench._shared.atomic import atomic_write_text
from sassi_bench._shared.tables import html_table
from sassi_bench.plots.html import figure_base64, page

__all__ = ["shift_map_figure", "trend_figure", "write_trend_html"]

_VERDICT_COLOURS = {"holds": "#2e7d32", "recalibrate": "#c62828"}


def _figure(*args, **kwargs):
    from matplotlib.figure import Figure

    return Figure(*args, **kwargs)


def _times(rows: Sequence[Mapping[str, Any]]) -> list[datetime]:
    return [datetime.fromisoformat(str(r["checked_utc"])) for r in rows]


def shift_map_figure(check):
    """One health check's streak shifts over the SLM: each pinhole (colour) and the
    fitted map's contours.

    Parameters
    ----------
    check
        A :class:`~sassi_bench.reduce.health.HealthCheck`.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    Not run here (it needs a procedure's result)::

        fig = shift_map_figure(check)
    """
    fig = _figure(figsize=(7.5, 4.8), layout="constrained")
    ax = fig.subplots()
    shifts, field_map = check.shifts, check.field
    limit = max(float(np.nanmax(np.abs(shifts.dx))), check.tolerances["shift_max_px"])
    dots = ax.scatter(shifts.u, shifts.v, c=shifts.dx, cmap="RdBu_r", vmin=-limit, vmax=limit,
                      s=30, edgecolors="0.3", linewidths=0.3)  # fmt: skip
    u_levels, v_levels = np.unique(field_map.u), np.unique(field_map.v)
    grid = field_map.dx.reshape(v_levels.size, u_levels.size)
    lines = ax.contour(u_levels, v_levels, grid, colors="k", linewidths=0.6)
    ax.clabel(lines, fontsize=7, fmt="%.3f")
    fig.colorbar(dots, ax=ax, label="shift along the dispersion (camera px)")
    ax.set_xlabel("SLM column")
    ax.set_ylabel("SLM row")
    ax.invert_yaxis()
    ax.set_title(
        f"{check.rig} {check.bundle_version} under {check.light}: mean "
        f"{field_map.mean_px:+.3f} px, max {field_map.max_px:.3f} px ({check.verdict})",
        fontsize=10,
    )
    return fig


def trend_figure(rows: Sequence[Mapping[str, Any]]):
    """The health checks' figures against time.

    Parameters
    ----------
    rows
        History rows (:meth:`~sassi_bench.storage.health_history.HealthHistory.rows`),
        oldest first.

    Returns
    -------
    matplotlib.figure.Figure

    Examples
    --------
    >>> row = {"checked_utc": "2026-11-25T09:00:00+00:00", "shift_x_max_px": 0.02,
    ...        "shift_x_mean_px": 0.01, "wavelength_max_nm": 0.05, "tolerance_px": 0.1,
    ...        "tolerance_nm": 0.3, "verdict": "holds", "bundle_version": "v0001"}
    >>> len(trend_figure([row]).axes)
    2
    """
    fig = _figure(figsize=(10, 6), layout="constrained")
    ax_px, ax_nm = fig.subplots(2, 1, sharex=True)
    times = _times(rows)
    colours = [_VERDICT_COLOURS.get(str(r["verdict"]), "0.5") for r in rows]
    ax_px.plot(times, [r["shift_x_max_px"] for r in rows], "-", color="0.6", lw=0.8)
    ax_px.scatter(times, [r["shift_x_max_px"] for r in rows], c=colours, s=28, zorder=3,
                  label="largest shift over the field")  # fmt: skip
    ax_px.plot(times, [r["shift_x_mean_px"] for r in rows], "--", color="C0", lw=1.0,
               marker=".", label="mean shift")  # fmt: skip
    ax_nm.plot(times, [r["wavelength_max_nm"] for r in rows], "-", color="0.6", lw=0.8)
    ax_nm.scatter(times, [r["wavelength_max_nm"] for r in rows], c=colours, s=28, zorder=3,
                  label="largest implied wavelength error")  # fmt: skip
    if rows:
        tol_px, tol_nm = float(rows[-1]["tolerance_px"]), float(rows[-1]["tolerance_nm"])
        for ax, tol in ((ax_px, tol_px), (ax_nm, tol_nm)):
            ax.axhline(tol, color="#c62828", lw=1.2, ls=":", label=f"tolerance {tol:g}")
            if ax is ax_px:
                ax.axhline(-tol, color="#c62828", lw=1.2, ls=":")
    for previous, row, when in zip(rows, rows[1:], times[1:], strict=False):
        if row["bundle_version"] != previous["bundle_version"]:
            for ax in (ax_px, ax_nm):
                ax.axvline(when, color="0.3", lw=0.8, ls="--")
            ax_px.annotate(str(row["bundle_version"]), (when, ax_px.get_ylim()[1]),
                           fontsize=7, va="top")  # fmt: skip
    ax_px.set_ylabel("streak shift (camera px)")
    ax_nm.set_ylabel("wavelength error (nm)")
    ax_nm.set_xlabel("check time (UTC); green holds, red recalibrate")
    from matplotlib.dates import AutoDateLocator, ConciseDateFormatter

    locator = AutoDateLocator()
    ax_nm.xaxis.set_major_locator(locator)
    ax_nm.xaxis.set_major_formatter(ConciseDateFormatter(locator))
    ax_px.legend(fontsize=8, loc="best")
    ax_nm.legend(fontsize=8, loc="best")
    ax_px.set_title("Calibration health checks", fontsize=11)
    return fig


def write_trend_html(
    rows: Sequence[Mapping[str, Any]], path: str | os.PathLike[str], *, rig: str | None = None
) -> Path:
    """Write the history's trend plot and table as one self-contained HTML page.

    Parameters
    ----------
    rows
        History rows, oldest first.
    path
        The page to write (atomically).
    rig
        The rig named in the title.

    Returns
    -------
    Path
        ``path``.

    Examples
    --------
    >>> import tempfile
    >>> row = {"checked_utc": "2026-11-25T09:00:00+00:00", "shift_x_max_px": 0.02,
    ...        "shift_x_mean_px": 0.01, "wavelength_max_nm": 0.05, "wavelength_rms_nm": 0.02,
    ...        "tolerance_px": 0.1, "tolerance_nm": 0.3, "verdict": "holds",
    ...        "bundle_version": "v0001", "rig": "sim", "light": "lamp:HgAr",
    ...        "shift_y_max_px": 0.01, "processing_s": 1.2}
    >>> out = write_trend_html([row], Path(tempfile.mkdtemp()) / "trend.html")
    >>> "Calibration health" in out.read_text()
    True
    """
    title = "Calibration health checks" + (f" of {rig}" if rig else "")
    fig = trend_figure(rows)
    image = f'<img src="data:image/png;base64,{figure_base64(fig)}" alt="trend">'
    header = ["time (UTC)", "bundle", "light", "max shift (px)", "mean shift (px)",
              "max error (nm)", "row shift (px)", "processing (s)", "verdict"]  # fmt: skip
    table_rows = []
    for r in reversed(rows):
        bad = r["verdict"] != "holds"
        table_rows.append(
            [
                html.escape(str(r["checked_utc"])),
                html.escape(str(r["bundle_version"])),
                html.escape(str(r["light"])),
                f"{float(r['shift_x_max_px']):.3f}",
                f"{float(r['shift_x_mean_px']):+.3f}",
                f"{float(r['wavelength_max_nm']):.3f}",
                f"{float(r['shift_y_max_px']):.3f}",
                f"{float(r['processing_s']):.1f}",
                f'<td class="{"bad" if bad else "ok"}">{html.escape(str(r["verdict"]))}</td>',
            ]
        )
    body = (
        f"<h1>{html.escape(title)}</h1>"
        f"<p>{len(rows)} check{'' if len(rows) == 1 else 's'}. "
        "Tolerances as recorded with the latest check.</p>"
        f"{image}<h2>Checks (newest first)</h2>{html_table(header, table_rows, left=3)}"
    )
    out = Path(path)
    atomic_write_text(out, page(title, body), overwrite=True)
    return out
