"""The snapshot validation report: one self-contained HTML file and a JSON of every figure.

Same form as the Macbeth report (:mod:`sassi_bench.validate.report`): base64 PNGs in the
HTML, and the data behind every figure, the checks and the provenance in the JSON.
"""

from __future__ import annotations

import html
import json
import os
from pathlib import Path
from typing import Any

from sassi_bench._shared.tables import html_table
from sassi_bench.plots.html import (
    check_rows,
    figure_base64,
    image_tags,
    jsonable,
    page,
    write_report_files,
)
from sassi_bench.plots.snapshot import snapshot_figures
from sassi_bench.provenance import package_version
from sassi_bench.validate.snapshot import SnapshotValidation

__all__ = ["snapshot_report_data", "write_snapshot_report"]


def snapshot_report_data(
    result: SnapshotValidation, points: int = 4
) -> tuple[dict[str, Any], dict[str, Any]]:
    """The report's JSON document and its figures (name -> matplotlib figure)."""
    figures = snapshot_figures(result, points)
    doc = {
        "kind": "snapshot_validation",
        "created": result.created,
        "software": f"sassi-bench {package_version()}",
        "rig": result.rig_name,
        "bundle_version": result.bundle_version,
        "scene": result.scene,
        "reference": result.reference_source,
        "units": result.units,
        "passed": result.passed,
        "checks": [c.to_manifest() for c in result.checks],
        "spacing": result.spacing,
        "settings": result.settings,
        "notes": result.notes,
        "snapshots": {
            name: {
                "mask": run.kind,
                "open_pixels": int(run.mask.sum()),
                "regions": int(run.labels.max()) + 1,
                "exposure_s": run.exposure_s,
                "low_light": run.low_light,
                "sessions": run.sessions,
                "scores": {m: s.to_dict() for m, s in run.scores.items()},
                "detail_psnr_db": run.detail_psnr_db,
                "error_split": run.error_split,
            }
            for name, run in result.runs.items()
        },
        "video": result.video,
        "figures": {name: data for name, (_, data) in figures.items()},
    }
    return jsonable(doc), {name: fig for name, (fig, _) in figures.items()}


def _scores_table(doc: dict[str, Any]) -> str:
    rows = []
    for name, snap in doc["snapshots"].items():
        for method, s in snap["scores"].items():
            rows.append(
                [
                    f'<td class="l">{html.escape(name)}</td>',
                    f'<td class="l">{method}</td>',
                    str(snap["open_pixels"]),
                    f"{s['psnr_db']:.2f}",
                    f"{s['psnr_affine_db']:.2f}",
                    f"{s['ssim']:.4f}",
                    f"{s['spectral_angle_deg']:.2f}",
                    f"{snap['detail_psnr_db'][method]:.2f}",
                ]
            )
    return html_table(
        ["snapshot", "method", "open px", "PSNR (dB)", "PSNR affine (dB)", "SSIM",
         "angle (deg)", "detail PSNR (dB)"],
        rows, left=2,
    )  # fmt: skip


def _pose_text(pose: dict[str, Any] | None) -> str:
    if pose is None:
        return "shift (0, 0) px, 0°"
    dx, dy = pose["shift_px"]
    return f"shift ({dx:g}, {dy:g}) px, {pose['rotation_deg']:g}°"


def _video_table(doc: dict[str, Any]) -> str:
    if not doc["video"]:
        return ""
    rows = [
        [
            str(f["frame"]),
            _pose_text(f["pose"]),
            str(f["open_pixels"]),
            f"{f['rank1']['psnr_affine_db']:.2f}",
            f"{f['guided']['psnr_affine_db']:.2f}",
        ]
        for f in doc["video"]
    ]
    return html_table(["frame", "pose", "open px", "rank-1 (dB)", "guided (dB)"], rows)


def _html(doc: dict[str, Any], images: dict[str, str]) -> str:
    esc = html.escape
    verdict = "PASS" if doc["passed"] else "FAIL"
    checks = html_table(["check", "value", "tolerance", "result"], check_rows(doc["checks"], ".2f"))
    settings = html_table(
        ["setting", "value"],
        [[f'<td class="l">{esc(k)}</td>', f'<td class="l">{esc(str(v))}</td>']
         for k, v in doc["settings"].items()],
        left=2,
    )  # fmt: skip
    img = image_tags(images)
    notes = "".join(f'<div class="note">{esc(n)}</div>' for n in doc["notes"])
    first = next(iter(doc["snapshots"].values()))["scores"]
    video = ""
    if doc["video"]:
        video = f"<h2>Video of the moving scene</h2>{img['video']}{_video_table(doc)}"
    comparison = ""
    names = list(doc["snapshots"])
    split = next(iter(doc["snapshots"].values()))["error_split"]
    split_text = (
        f"<p>Where the error comes from ({esc(names[0])} snapshot): at the open pixels the "
        f"measured spectra agree with the scan at {split['samples_psnr_db']:.1f} dB "
        "(calibration and extraction); rank-1 fed with the scan's own spectra at the same "
        f"pixels reaches {split['rank1_from_scan_psnr_db']:.1f} dB after the affine fit, "
        "the most this mask and its regions allow (spatial sampling).</p>"
    )
    if len(names) > 1:
        parts = [
            f"{esc(n)} {doc['snapshots'][n]['detail_psnr_db']['rank1']:.1f} dB"
            for n in names
            if not n.endswith("low_light")
        ]
        comparison = (
            "<p>Detail PSNR (rank-1, on the pixels of strongest gradient in the scan: "
            f"edges and thin structures): {', '.join(parts)}.</p>"
        )
    return page(
        f"Snapshot validation {doc['rig']} {doc['bundle_version']}: {verdict}",
        f"""<h1>SASSI snapshot validation: rig {esc(doc["rig"])},
bundle {esc(doc["bundle_version"])}, scene {esc(doc["scene"])}</h1>
<p><span class="verdict {"pass" if doc["passed"] else "fail"}">{verdict}</span>
&nbsp; rank-1 {first["rank1"]["psnr_db"]:.1f} dB ({first["rank1"]["psnr_affine_db"]:.1f} dB
after the affine fit), guided filter {first["guided"]["psnr_db"]:.1f} dB
({first["guided"]["psnr_affine_db"]:.1f} dB) against the {esc(doc["reference"])} &nbsp;
<small>{esc(doc["created"])}, {esc(doc["software"])}</small></p>
<div class="flex"><div><h2>Tolerances</h2>{checks}</div><div><h2>Run</h2>{settings}</div></div>
{notes}
<h2>Scores against the scan</h2>{_scores_table(doc)}{split_text}{comparison}
<h2>Masks and regions</h2>{img["masks"]}
<h2>Reconstruction and error maps</h2>{img["reconstruction"]}
<h2>Per-band PSNR</h2>{img["band_psnr"]}
<h2>Spectra at a few pixels</h2>{img["spectra"]}
{video}""",
    )


def write_snapshot_report(
    result: SnapshotValidation, out: str | os.PathLike[str], points: int = 4
) -> tuple[Path, Path]:
    """Write ``snapshot_report.html`` and ``snapshot_report.json`` into folder ``out``
    (never over an earlier report).

    Examples
    --------
    Not run here (it needs a scan or a procedure's result)::

        write_snapshot_report(result, "report/")
        # (PosixPath('report/snapshot_report.html'), PosixPath('report/snapshot_report.json'))
    """
    doc, figures = snapshot_report_data(result, points)
    images = {name: figure_base64(fig) for name, fig in figures.items()}
    files = {
        "snapshot_report.html": _html(doc, images),
        "snapshot_report.json": json.dumps(doc, indent=1, allow_nan=False),
    }
    html_path, json_path = write_report_files(out, files, "snapshot report")
    return html_path, json_path
