"""The whole calibration chain: spectral sweeps and fits, radiometric response, guide
homography, Macbeth validation; one bundle and its report.

The stages run in a staging data root beside the lab's
(``<data>/staging/<session id>/``: their raw sessions, so an interrupted chain resumes,
and the intermediate bundle versions each stage builds on). At the end the last staged
bundle's models are published once in the lab's data root, with every stage's quality
checks, procedures, input sessions and figures, and the Macbeth report in ``report/``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from sassi_bench._shared.atomic import atomic_write_bytes
from sassi_bench._shared.memory import release_memory
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.streak_pitch import check_scan_pitch
from sassi_bench.bundle import QualityCheck, load, publish_derived
from sassi_bench.bundle.derive import derived_checks
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.paths import data_root
from sassi_bench.procedure import load_procedure, with_changes
from sassi_bench.rig.rig import Rig
from sassi_bench.storage.keep import KeptFrames, keep_frames
from sassi_bench.validate.report import render_report
from sassi_bench.workflows.guide import run_guide_registration
from sassi_bench.workflows.macbeth import run_macbeth
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.scan import check_scan, response_source, run_response
from sassi_bench.workflows.spectral import run_spectral_calibration

__all__ = ["FullCalibration", "run_full_calibration"]


@dataclass
class FullCalibration:
    """What the chain produced: every stage's checks, the bundle, the report, and the raw
    frames it kept (``kept``; every frame while the bundle is unpublished)."""

    checks: list[QualityCheck]
    bundle_path: Path | None
    report_html: Path
    stages: dict[str, Any]
    kept: KeptFrames

    @property
    def passed(self) -> bool:
        """Whether every tolerance of every stage passed."""
        return all(c.passed for c in self.checks)


def _stage_procedure(kind: str, name_or_path: str) -> dict[str, Any]:
    return load_procedure(kind, None if name_or_path == kind else name_or_path)


@drives_rig("calibrate")
def run_full_calibration(
    rig: Rig,
    procedure: Mapping[str, Any],
    *,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    out: str | os.PathLike[str] | None = None,
    progress: bool = True,
    allow_failed: bool = False,
) -> FullCalibration:
    """Run the full calibration chain on a rig and publish one bundle with its report.

    Parameters
    ----------
    rig
        Device handles (virtual or real).
    procedure
        A validated full-calibration procedure (``load_procedure("full_calibration")``).
    session_id
        Names the chain's staging folder and raw sessions; an existing one resumes.
    data
        The lab's data root (the bundle is published there).
    out
        Folder for the Macbeth report (default ``<data>/reports/<session id>``).
    progress
        Show progress bars.
    allow_failed
        Publish even if a tolerance failed (the bundle is then marked as failed).

    Returns
    -------
    FullCalibration

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> result = run_full_calibration(
    ...     open_rig("sim"), load_procedure("full_calibration"))  # doctest: +SKIP
    >>> result.passed, result.bundle_path  # doctest: +SKIP
    (True, PosixPath('calib_data/sim/v0001'))
    """
    response_cfg = procedure["response"]
    check_scan(rig, "white", response_cfg["light"], (100, 5))
    response_source(rig)  # the lamp's spectrum must be known before anything is captured
    base = session_id or "full-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    root = data_root(data)
    staging = root / "staging" / base
    report_dir = Path(out) if out is not None else root / "reports" / base
    spectral_proc = _stage_procedure("spectral_calibration", procedure["spectral_procedure"])
    guide_proc = _stage_procedure("guide_registration", procedure["guide_procedure"])
    macbeth_proc = _stage_procedure("macbeth_validation", procedure["macbeth_procedure"])
    # Every scan of the chain, before anything is captured: a streak too long for a pitch
    # would otherwise fail only at the scan that uses it.
    for what, stage in (("guide scan", guide_proc), ("Macbeth scan", macbeth_proc)):
        check_scan_pitch(rig.description, tuple(stage["scan"]["pitch_px"]), what)
    macbeth_proc = with_changes(
        macbeth_proc,
        white_reference={
            **macbeth_proc["white_reference"],
            "source": procedure["macbeth_white_reference"],
        },
    )

    spectral = run_spectral_calibration(
        rig, spectral_proc, session_id=f"{base}-spectral", data=staging, progress=progress,
        allow_failed=True,
    )  # fmt: skip
    release_memory()  # each stage's arrays go before the next one's come
    staged = load(
        run_response(
            rig, load(spectral.bundle_path), light=response_cfg["light"],
            every=int(response_cfg["every"]), reflectance=float(response_cfg["reflectance"]),
            session_id=f"{base}-response", data=staging, progress=progress, allow_failed=True,
        )
    )  # fmt: skip
    release_memory()
    guide = run_guide_registration(
        rig, staged, guide_proc, session_id=f"{base}-guide", data=staging, progress=progress,
        allow_failed=True,
    )  # fmt: skip
    staged = load(guide.bundle_path)
    release_memory()
    macbeth = run_macbeth(
        rig, staged, macbeth_proc, session_id=f"{base}-macbeth", data=staging,
        progress=progress,
    )  # fmt: skip
    staged_at = f"the staged bundle {staged.path.relative_to(root).as_posix()} of this run"
    report = render_report(macbeth, staged, macbeth_proc, scanned_from=staged_at)

    # The staged bundle carries the spectral, response and guide checks.
    checks = derived_checks(staged, "macbeth", macbeth.checks)
    reports: dict[str, Any] = {f"spectral_{k}.png": v for k, v in spectral.figures.items()}
    reports.update({f"guide_{k}.png": v for k, v in guide.figures.items()})
    # Rendered against the published manifest, so the report names its own version.
    reports.update({"macbeth_report.html": report.html, "macbeth_report.json": report.json})
    chart = Session.open(macbeth.settings["chart_session"], data=staging)
    bundle_path = None
    if all(c.passed for c in checks) or allow_failed:
        bundle_path = publish_derived(
            staged,
            stage="macbeth",
            rig=rig.description,
            checks=macbeth.checks,
            residuals=macbeth.summary(),
            procedure={  # the response and guide procedures come with the staged bundle
                "full_calibration": dict(procedure),
                "spectral_calibration": spectral_proc,
                "macbeth_validation": macbeth_proc,
            },
            inputs=[{"id": chart.id, "sha256": chart.sha256(), "kind": "session"}],
            reports=reports,
            allow_failed=allow_failed,
            data=root,
        )
        report_dir.mkdir(parents=True, exist_ok=True)
        for name in ("macbeth_report.html", "macbeth_report.json"):
            raw = (bundle_path / "report" / name).read_bytes()
            atomic_write_bytes(report_dir / name, raw, overwrite=False)
        html = report_dir / "macbeth_report.html"
    else:
        unpublished = {
            **thaw(staged.manifest),
            "version": None,
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
            "passed": False,
            "quality": {"checks": [c.to_manifest() for c in checks]},
        }
        html, _ = report.write(report_dir, unpublished)
    # Frames go only once the bundle is published: until then a re-run resumes from them.
    kept = keep_frames(staging, base, procedure.get("keep", "all") if bundle_path else "all")
    stages = {"spectral": spectral, "guide": guide, "macbeth": macbeth, "staging": staging}
    return FullCalibration(checks, bundle_path, html, stages, kept)
