"""The Macbeth validation report: one self-contained HTML file and a JSON of every figure.

The HTML embeds its plots as base64 PNGs (no other files, opens anywhere, can be mailed);
the JSON holds the data behind every figure, the checks and the provenance, so numbers
can be re-plotted or compared between bundles.
"""

from __future__ import annotations

import base64
import html
import io
import json
import os
from collections.abc import Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench import __version__
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.plots.macbeth import macbeth_figures
from sassi_bench.validate.macbeth import MacbethResult

__all__ = ["report_data", "write_report"]

_CSS = """
body { font-family: system-ui, sans-serif; margin: 24px auto; max-width: 1320px; color: #222; }
h1 { font-size: 22px; margin-bottom: 4px; } h2 { font-size: 17px; margin-top: 28px; }
.verdict { display: inline-block; padding: 6px 16px; border-radius: 4px; color: white;
           font-weight: bold; font-size: 18px; }
.pass { background: #2e7d32; } .fail { background: #c62828; }
table { border-collapse: collapse; font-size: 13px; margin: 8px 0; }
td, th { border: 1px solid #ccc; padding: 3px 8px; text-align: right; }
th { background: #f2f2f2; } td.l, th.l { text-align: left; }
td.bad { color: #c62828; font-weight: bold; }
img { max-width: 100%; border: 1px solid #ddd; margin: 6px 0; }
.note { background: #fff8e1; border-left: 4px solid #f9a825; padding: 6px 12px; margin: 6px 0;
        font-size: 14px; }
.flex { display: flex; gap: 24px; flex-wrap: wrap; align-items: flex-start; }
"""


def _png(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=100)
    return base64.b64encode(buffer.getvalue()).decode("ascii")


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def report_data(
    result: MacbethResult, bundle: CalibrationBundle, procedure: Mapping[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The report's JSON document and the figures (name -> matplotlib figure)."""
    figures = macbeth_figures(result, bundle, procedure)
    doc = {
        "kind": "macbeth_validation",
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "software": f"sassi-bench {__version__}",
        "passed": result.passed,
        "summary": result.summary(),
        "checks": [c.to_manifest() for c in result.checks],
        "usable_band_nm": list(result.band_nm),
        "notes": result.notes,
        "settings": result.settings,
        "tolerances": dict(procedure["tolerances"]),
        "patches": [
            {
                "index": k + 1,
                "name": result.patch_names[k],
                "pixels": int(result.pixels[k]),
                "spectral_angle_deg": float(result.angle_deg[k]),
                "rmse": float(result.rmse[k]),
                "de00": float(result.de00[k]),
            }
            for k in range(len(result.patch_names))
        ],
        "figures": {name: data for name, (_, data) in figures.items()},
    }
    return _jsonable(doc), {name: fig for name, (fig, _) in figures.items()}


def _table(header: list[str], rows: list[list[str]], left: int = 1) -> str:
    head = "".join(f'<th class="{"l" if i < left else ""}">{h}</th>' for i, h in enumerate(header))
    body = "".join(
        "<tr>" + "".join(cell if cell.startswith("<td") else f"<td>{cell}</td>" for cell in row)
        for row in rows
    )
    return f"<table><tr>{head}</tr>{body}</table>"


def _html(doc: Mapping[str, Any], images: Mapping[str, str], bundle: CalibrationBundle) -> str:
    esc = html.escape
    verdict = "PASS" if doc["passed"] else "FAIL"
    checks = _table(
        ["check", "value", "tolerance", "result"],
        [
            [
                f'<td class="l">{esc(c["name"])}</td>',
                f"{c['value']:.3f} {esc(c['unit']) if c['unit'] != '1' else ''}",
                f"{esc(c['comparison'])} {c['tolerance']:g}",
                "pass" if c["passed"] else '<td class="bad">FAIL</td>',
            ]
            for c in doc["checks"]
        ],
    )
    tol = doc["tolerances"]
    patches = _table(
        ["patch", "pixels", "angle (deg)", "RMSE", "dE00"],
        [
            [
                f'<td class="l">{p["index"]} {esc(p["name"])}</td>',
                str(p["pixels"]),
                f"{p['spectral_angle_deg']:.2f}",
                f"{p['rmse']:.4f}",
                f"{p['de00']:.2f}"
                if p["de00"] <= tol["max_de00"]
                else f'<td class="bad">{p["de00"]:.2f}</td>',
            ]
            for p in doc["patches"]
        ],
    )
    settings = _table(
        ["setting", "value"],
        [[f'<td class="l">{esc(k)}</td>', f'<td class="l">{esc(str(v))}</td>']
         for k, v in doc["settings"].items()],
        left=2,
    )  # fmt: skip
    wl = doc["figures"]["wavelength_calibration"]
    bundle_checks = _table(
        ["wavelength calibration check", "value", "tolerance", "result"],
        [
            [
                f'<td class="l">{esc(str(c.get("name")))}</td>',
                f"{c.get('value', float('nan')):.4g} {esc(str(c.get('unit', '')))}",
                f"{esc(str(c.get('comparison', '')))} {c.get('tolerance', '')}",
                "pass" if c.get("passed") else '<td class="bad">FAIL</td>',
            ]
            for c in wl["bundle_checks"]
        ],
    )
    notes = "".join(f'<div class="note">{esc(n)}</div>' for n in doc["notes"])
    summary = doc["summary"]
    img = {k: f'<img alt="{k}" src="data:image/png;base64,{v}">' for k, v in images.items()}
    res = np.asarray(wl["bin_resolution_nm"])
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<title>Macbeth validation {esc(bundle.rig_name)}/{esc(bundle.version)}: {verdict}</title>
<style>{_CSS}</style></head><body>
<h1>Macbeth ColorChecker validation: {esc(bundle.rig_name)} / {esc(bundle.version)}</h1>
<p><span class="verdict {"pass" if doc["passed"] else "fail"}">{verdict}</span>
&nbsp; mean dE00 {summary["mean_de00"]:.2f}, max dE00 {summary["max_de00"]:.2f},
mean spectral angle {summary["mean_spectral_angle_deg"]:.2f}°, usable band
{doc["usable_band_nm"][0]:.0f}-{doc["usable_band_nm"][1]:.0f} nm &nbsp;
<small>{esc(doc["created"])}, {esc(doc["software"])}</small></p>
<div class="flex"><div><h2>Tolerances</h2>{checks}</div><div><h2>Run</h2>{settings}</div></div>
{notes}
<h2>Patch spectra</h2>{img["spectra"]}
<h2>Colour difference</h2>{img["de00"]}
<h2>Measured chart and reference</h2>{img["chart"]}
<div class="flex"><div><h2>Per patch</h2>{patches}</div>
<div><h2>Patch localisation</h2>{img["localisation"]}</div></div>
<h2>Wavelength calibration of the bundle</h2>
<p>{len(wl["bin_centres_nm"])} bins from {wl["bin_edges_nm"][0]:.1f} to
{wl["bin_edges_nm"][-1]:.1f} nm, resolution {res.min():.1f}-{res.max():.1f} nm per bin;
bundle published {esc(bundle.created)}, quality {"passed" if bundle.passed else "FAILED"}.</p>
{img["wavelength_calibration"]}
{bundle_checks}
</body></html>
"""


def write_report(
    result: MacbethResult,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    out: str | os.PathLike[str],
) -> tuple[Path, Path]:
    """Write ``macbeth_report.html`` and ``macbeth_report.json`` into folder ``out``.

    Returns
    -------
    html_path, json_path : Path

    Examples
    --------
    >>> write_report(result, bundle, procedure, "report/")  # doctest: +SKIP
    (PosixPath('report/macbeth_report.html'), PosixPath('report/macbeth_report.json'))
    """
    folder = Path(out)
    folder.mkdir(parents=True, exist_ok=True)
    doc, figures = report_data(result, bundle, procedure)
    images = {name: _png(fig) for name, fig in figures.items()}
    html_path = folder / "macbeth_report.html"
    json_path = folder / "macbeth_report.json"
    html_path.write_text(_html(doc, images, bundle), encoding="utf-8")
    json_path.write_text(json.dumps(doc, indent=1, allow_nan=False), encoding="utf-8")
    return html_path, json_path
