"""The Macbeth validation report: one self-contained HTML file and a JSON of every figure.

The HTML embeds its plots as base64 PNGs (no other files, opens anywhere, can be mailed);
the JSON holds the data behind every figure, the checks and the provenance, so numbers
can be re-plotted or compared between bundles.

A report describes one bundle: its version, publication time, status and every quality
check of every stage. :func:`render_report` makes the figures once; the returned
:class:`MacbethReport` then writes the HTML and JSON for a bundle's manifest, so a report
published inside a new bundle (``publish(..., reports={"x.html": report.html})``) names
the version it is published as, and states whether that bundle's models are the ones the
scan was assembled with.
"""

from __future__ import annotations

import html
import json
import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from sassi_bench._shared.tables import html_table
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.bundle.loader import REPORT_DIR
from sassi_bench.plots.html import (
    check_rows,
    figure_base64,
    image_tags,
    jsonable,
    page,
    write_report_files,
)
from sassi_bench.plots.macbeth import macbeth_figures
from sassi_bench.provenance import package_version
from sassi_bench.validate.band_error import (
    close_to_tolerance,
    failing_patches,
    patch_band_error,
)
from sassi_bench.validate.macbeth import MacbethResult

__all__ = [
    "MAX_DRAWN",
    "MacbethReport",
    "figure_links",
    "render_report",
    "report_data",
    "write_report",
]

#: Failing patches whose per-band error the report draws at most (worst first).
MAX_DRAWN = 4


def report_data(
    result: MacbethResult, bundle: CalibrationBundle, procedure: Mapping[str, Any]
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The report's JSON document (without its ``bundle`` section) and the figures
    (name -> matplotlib figure)."""
    tolerances = procedure["tolerances"]
    failing = failing_patches(result, tolerances)
    # Failing patches, or else the one of largest RMSE, so a lab sees where even a pass is
    # weakest (with advice only when it is close to a tolerance).
    drawn = failing[:MAX_DRAWN] or [int(np.argmax(result.rmse))]
    band_errors = [
        patch_band_error(result, k, bool(failing), close_to_tolerance(result, k, tolerances))
        for k in drawn
    ]
    figures = macbeth_figures(result, bundle, procedure, band_errors)
    doc = {
        "kind": "macbeth_validation",
        "created": datetime.now(UTC).isoformat(timespec="seconds"),
        "software": f"sassi-bench {package_version()}",
        "passed": result.passed,
        "summary": result.summary(),
        "noise_floors": result.noise_floors(),
        "checks": [c.to_manifest() for c in result.checks],
        "usable_band_nm": list(result.band_nm),
        "notes": result.notes,
        "band_errors": [e.to_dict() for e in band_errors],
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
                **{f"noise_{name}": float(values[k]) for name, values in result.noise.items()},
            }
            for k in range(len(result.patch_names))
        ],
        "figures": {name: data for name, (_, data) in figures.items()},
    }
    return jsonable(doc), {name: fig for name, (fig, _) in figures.items()}


def _array_hashes(manifest: Mapping[str, Any]) -> dict[str, str]:
    return {name: str(entry["sha256"]) for name, entry in manifest.get("arrays", {}).items()}


def bundle_identity(
    manifest: Mapping[str, Any],
    scanned_with: Mapping[str, Any],
    scanned_from: str | None = None,
) -> dict[str, Any]:
    """What a report says about the bundle it describes (the ``bundle`` of its JSON).

    Parameters
    ----------
    manifest
        The manifest of the bundle the report describes (published, or about to be; a
        ``version`` of None: not published, e.g. a chain that failed a tolerance).
    scanned_with
        The manifest of the bundle the scans were assembled with.
    scanned_from
        Where that bundle is, when not under the data root as ``rig/version`` (a
        calibration chain's staged bundle: ``staging/<run>/sim/v0003``).

    Examples
    --------
    >>> m = {"rig_name": "sim", "version": "v0002", "created": "2025-01-01T00:00:00Z",
    ...      "passed": True, "override": False, "quality": {"checks": []},
    ...      "arrays": {"x": {"sha256": "ab"}}}
    >>> identity = bundle_identity(m, {**m, "version": "v0001"})
    >>> identity["version"], identity["scanned_with"], identity["models_identical"]
    ('v0002', 'sim/v0001', True)
    """
    version = manifest.get("version")
    return {
        "rig_name": str(manifest["rig_name"]),
        "version": None if version is None else str(version),
        "created": str(manifest["created"]),
        "passed": bool(manifest["passed"]),
        "override": bool(manifest.get("override", False)),
        "checks": [dict(c) for c in manifest["quality"]["checks"]],
        "scanned_with": scanned_from or f"{scanned_with['rig_name']}/{scanned_with['version']}",
        "models_identical": _array_hashes(manifest) == _array_hashes(scanned_with),
        "staged": scanned_from is not None,
        "findings": bundle_findings(manifest["quality"]),
    }


def bundle_findings(quality: Mapping[str, Any]) -> list[str]:
    """What a bundle's quality record says beyond its checks, one sentence each: laser
    lines fitted at an estimate or found off their labels, and how much the radiometric
    response depends on the lamp temperature it assumed.

    Examples
    --------
    >>> sensitivity = {"temperature_k": 3000.0, "delta_k": 100.0, "max_relative_change": 0.106}
    >>> bundle_findings({"residuals": {"response": {"lamp_temperature_sensitivity": sensitivity}}})
    ['Radiometric response under a blackbody of 3000 K: a lamp 100 K cooler or hotter would \
change its spectral shape by up to 10.6 % (relative to the median bin).']
    """
    found = [str(note) for note in quality.get("notes", [])]
    lamp = quality.get("residuals", {}).get("response", {}).get("lamp_temperature_sensitivity")
    if lamp:
        found.append(
            f"Radiometric response under a blackbody of {lamp['temperature_k']:g} K: a lamp "
            f"{lamp['delta_k']:g} K cooler or hotter would change its spectral shape by up to "
            f"{100 * lamp['max_relative_change']:.1f} % (relative to the median bin)."
        )
    return found


def _setting(key: str, value: Any) -> str:
    if key == "patches_detected" and isinstance(value, int) and value < 24:
        return f"{value} of 24 (the 6 x 4 lattice was fitted to them)"
    return str(value)


def _picture_kind(settings: Mapping[str, Any]) -> str:
    """What the localisation picture shows, from the run's settings."""
    if settings.get("localisation_image") == "guide":
        return "the guide camera's image warped onto the SLM"
    light = str(settings.get("light", "led"))
    light = "the LED" if light == "led" else light
    return f"the scan's raw radiance under {light}, rendered as RGB, before the white reference"


def _bundle_paragraph(ident: Mapping[str, Any]) -> str:
    esc = html.escape
    checks = ident["checks"]
    passed = sum(1 for c in checks if c["passed"])
    status = "passed" if ident["passed"] else "FAILED (published with an override)"
    name = f"{ident['rig_name']}/{ident['version']}"
    # A calibration run's own staged models are named as such, not by their staging path.
    staged = ident.get("staged", False)
    if ident["version"] is None:
        scanned = "this calibration run's models" if staged else esc(ident["scanned_with"])
        return (
            f"Not published: {len(checks) - passed} of {len(checks)} quality checks of the "
            f"calibration failed (see below). The scans were assembled with {scanned}."
        )
    if ident["scanned_with"] == name:
        scan = "The scans were assembled with this bundle."
    elif staged and ident["models_identical"]:
        scan = (
            "The scans were assembled with this calibration run's models before they were "
            "published as this bundle (identical arrays)."
        )
    elif ident["models_identical"]:
        scan = (
            f"The scans were assembled with {esc(ident['scanned_with'])}, whose model "
            "arrays are identical to this bundle's."
        )
    else:
        scan = (
            f'<span class="bad">The scans were assembled with {esc(ident["scanned_with"])}, '
            "whose models differ from this bundle's.</span>"
        )
    return (
        f"Bundle {esc(name)}, created {esc(ident['created'])}, quality {status} "
        f"({passed} of {len(checks)} checks passed). {scan}"
    )


def _figure_links(links: Mapping[str, str]) -> str:
    """A list of links to the bundle's own figures (PNG files beside the report)."""
    if not links:
        return ""
    items = "".join(
        f'<li><a href="{html.escape(href)}">{html.escape(name)}</a></li>'
        for name, href in links.items()
    )
    return f"<h2>The bundle's figures</h2><ul>{items}</ul>"


def _html(
    doc: Mapping[str, Any], images: Mapping[str, str], links: Mapping[str, str] | None = None
) -> str:
    esc = html.escape
    ident = doc["bundle"]
    name = f"{esc(ident['rig_name'])} / {esc(ident['version'] or 'not published')}"
    verdict = "PASS" if doc["passed"] else "FAIL"
    floors = doc.get("noise_floors") or None
    header = ["check", "value", *(["noise floor"] if floors else []), "tolerance", "result"]
    checks = html_table(header, check_rows(doc["checks"], ".3f", floors))
    tol = doc["tolerances"]
    patches = html_table(
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
    shown = {k: v for k, v in doc["settings"].items() if k not in ("bundle", "bundle_passed")}
    settings = html_table(
        ["setting", "value"],
        [[f'<td class="l">{esc(k)}</td>', f'<td class="l">{esc(_setting(k, v))}</td>']
         for k, v in shown.items()],
        left=2,
    )  # fmt: skip
    wl = doc["figures"]["wavelength_calibration"]
    bundle_checks = html_table(
        ["bundle quality check (every stage)", "value", "tolerance", "result"],
        check_rows(ident["checks"], ".4g"),
    )
    notes = "".join(f'<div class="note">{esc(n)}</div>' for n in doc["notes"])
    summary = doc["summary"]
    img = image_tags(images)
    res = np.asarray(wl["bin_resolution_nm"])
    title = f"Macbeth validation {ident['rig_name']} / {ident['version'] or 'not published'}"
    return page(
        f"{title}: {verdict}",
        f"""<h1>Macbeth ColorChecker validation: {name}</h1>
<p><span class="verdict {"pass" if doc["passed"] else "fail"}">{verdict}</span>
&nbsp; mean dE00 {summary["mean_de00"]:.2f}, max dE00 {summary["max_de00"]:.2f},
mean spectral angle {summary["mean_spectral_angle_deg"]:.2f}°, usable band
{doc["usable_band_nm"][0]:.0f}-{doc["usable_band_nm"][1]:.0f} nm &nbsp;
<small>validated {esc(doc["created"])}, {esc(doc["software"])}</small></p>
<p>{_bundle_paragraph(ident)}</p>
<div class="flex"><div><h2>Tolerances</h2>{checks}</div><div><h2>Run</h2>{settings}</div></div>
{notes}
<h2>Where the error lies along the band</h2>
{"".join(f'<div class="note">{esc(e["sentence"])}</div>' for e in doc["band_errors"])}
{img["band_error"]}
<h2>Patch spectra</h2>{img["spectra"]}
<h2>Colour difference</h2>{img["de00"]}
<h2>Measured chart and reference</h2>{img["chart"]}
<div class="flex"><div><h2>Per patch</h2>{patches}</div>
<div><h2>Patch localisation</h2>
<p>The picture the chart was found on ({esc(_picture_kind(doc["settings"]))}), with the
square measured in each patch.</p>{img["localisation"]}</div></div>
<h2>The bundle: wavelength bins and quality checks</h2>
<p>{len(wl["bin_centres_nm"])} bins from {wl["bin_edges_nm"][0]:.1f} to
{wl["bin_edges_nm"][-1]:.1f} nm, resolution {res.min():.1f}-{res.max():.1f} nm per bin.</p>
{img["wavelength_calibration"]}
{bundle_checks}
{"".join(f'<div class="note">{esc(f)}</div>' for f in ident.get("findings", []))}
{_figure_links(links or {})}""",
    )


@dataclass(frozen=True)
class MacbethReport:
    """A rendered report (figures done) that writes its HTML and JSON for a bundle.

    Attributes
    ----------
    doc
        The JSON document without its ``bundle`` section.
    images
        Base64 PNG of every figure, by name.
    scanned_with
        Manifest of the bundle the scans were assembled with.
    scanned_from
        Where that bundle is, when not under the data root as ``rig/version``.
    """

    doc: Mapping[str, Any]
    images: Mapping[str, str]
    scanned_with: Mapping[str, Any]
    scanned_from: str | None = None

    @property
    def passed(self) -> bool:
        """Whether the validation passed its tolerances."""
        return bool(self.doc["passed"])

    def document(self, manifest: Mapping[str, Any] | None = None) -> dict[str, Any]:
        """The JSON document for the bundle of ``manifest`` (default: the scanned one)."""
        ident = bundle_identity(manifest or self.scanned_with, self.scanned_with, self.scanned_from)
        return jsonable({**self.doc, "bundle": ident})

    def html(
        self,
        manifest: Mapping[str, Any] | None = None,
        figure_links: Mapping[str, str] | None = None,
    ) -> str:
        """The self-contained HTML page for the bundle of ``manifest``; ``figure_links``
        (figure name -> URL relative to where the page is written) lists the bundle's own
        figures at its end."""
        return _html(self.document(manifest), self.images, figure_links)

    def json(self, manifest: Mapping[str, Any] | None = None) -> str:
        """The JSON text for the bundle of ``manifest``."""
        return json.dumps(self.document(manifest), indent=1, allow_nan=False)

    def write(
        self,
        out: str | os.PathLike[str],
        manifest: Mapping[str, Any] | None = None,
        figure_links: Mapping[str, str] | None = None,
    ) -> tuple[Path, Path]:
        """Write ``macbeth_report.html`` and ``macbeth_report.json`` into folder ``out``
        (never over an earlier report: :func:`~sassi_bench.plots.html.write_report_files`);
        the HTML lists ``figure_links`` (see :meth:`html`)."""
        files = {
            "macbeth_report.html": self.html(manifest, figure_links),
            "macbeth_report.json": self.json(manifest),
        }
        html_path, json_path = write_report_files(out, files, "Macbeth report")
        return html_path, json_path


def figure_links(
    names: Iterable[str], folder: str | os.PathLike[str], out: str | os.PathLike[str]
) -> dict[str, str]:
    """Links from a page in folder ``out`` to the figures ``names`` in ``folder`` (a
    bundle's ``report/``), relative so that they hold wherever the data root is mounted.

    Examples
    --------
    >>> figure_links(["map.png"], "lab/bundles/sim/v0003/report", "lab/reports/run-1")
    {'map.png': '../../bundles/sim/v0003/report/map.png'}
    """
    return {
        name: Path(os.path.relpath(Path(folder) / name, Path(out))).as_posix() for name in names
    }


def render_report(
    result: MacbethResult,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    scanned_from: str | None = None,
) -> MacbethReport:
    """Make the report's figures once; write it for any bundle with the same models.

    ``scanned_from`` says where ``bundle`` is when it is not a published version (a
    calibration chain's staged bundle), so the report never names a version of the data
    root that is another bundle.

    Examples
    --------
    Not run here (it needs a scan or a procedure's result)::

        report = render_report(result, staged_bundle, procedure)
        publish(models, ..., reports={"macbeth_report.html": report.html})
    """
    doc, figures = report_data(result, bundle, procedure)
    images = {name: figure_base64(fig) for name, fig in figures.items()}
    return MacbethReport(doc, images, bundle.manifest, scanned_from)


def write_report(
    result: MacbethResult,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    out: str | os.PathLike[str],
) -> tuple[Path, Path]:
    """Write ``macbeth_report.html`` and ``macbeth_report.json`` into folder ``out``; the
    HTML links the bundle's own figures (the PNGs in its ``report/``).

    Returns
    -------
    html_path, json_path : Path

    Examples
    --------
    Not run here (it needs a scan or a procedure's result)::

        write_report(result, bundle, procedure, "report/")
        # (PosixPath('report/macbeth_report.html'), PosixPath('report/macbeth_report.json'))
    """
    figures = sorted(name for name in bundle.manifest.get("reports", {}) if name.endswith(".png"))
    links = figure_links(figures, Path(bundle.path) / REPORT_DIR, out)
    return render_report(result, bundle, procedure).write(out, figure_links=links)
