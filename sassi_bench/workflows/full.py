"""The whole calibration chain: spectral sweeps and fits, radiometric response, guide
homography, Macbeth validation; one bundle and its report. Its steps, in order
(:data:`STEPS`): ``check``, ``spectral``, ``response``, ``guide``, ``macbeth``,
``publish`` and ``keep``.

The stages run in a staging data root beside the lab's
(``<data>/staging/<session id>/``: their raw sessions, so an interrupted chain resumes,
and the intermediate bundle versions each stage builds on). At the end the last staged
bundle's models are published once in the lab's data root, with every stage's quality
checks, procedures, input sessions and figures, and the Macbeth report in ``report/``;
then the raw frames the procedure's ``keep`` does not keep go.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import Any

from sassi_bench._shared.atomic import atomic_write_bytes
from sassi_bench._shared.memory import release_memory
from sassi_bench.acquire.plan_geometry import (
    planned_guide,
    planned_macbeth,
    planned_spectral,
    scan_pitch,
)
from sassi_bench.acquire.scan_plans import check_stride
from sassi_bench.acquire.session import Session
from sassi_bench.acquire.spectral_plans import check_lamp_pitch
from sassi_bench.acquire.streak_pitch import check_scan_pitch
from sassi_bench.bundle import QualityCheck, load, publish_derived
from sassi_bench.bundle.derive import derived_checks
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.paths import data_root
from sassi_bench.procedure import load_procedure, with_changes
from sassi_bench.reduce.response import response_source
from sassi_bench.rig.rig import Rig
from sassi_bench.storage.keep import KeptFrames, keep_frames
from sassi_bench.validate.report import figure_links, render_report
from sassi_bench.workflows.guide import run_guide_registration
from sassi_bench.workflows.macbeth import run_macbeth
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.scan import check_scan, run_response
from sassi_bench.workflows.spectral import run_spectral_calibration
from sassi_bench.workflows.steps import run_steps

__all__ = ["STEPS", "FullCalibration", "FullRun", "run_full_calibration"]


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


@dataclass
class FullRun:
    """The state of the calibration chain as its steps run: the devices, the procedure and
    where the run keeps its data; then every stage's procedure and result, the staged
    bundle each stage builds on, and the published bundle, its report and the frames kept.
    """

    rig: Rig
    procedure: Mapping[str, Any]
    base: str
    root: Path
    report_dir: Path
    progress: bool = True
    allow_failed: bool = False
    stage_procedures: dict[str, dict[str, Any]] = field(default_factory=dict)
    response_pitch: tuple[int, int] | None = None
    spectral: Any = None
    guide: Any = None
    macbeth: Any = None
    report: Any = None
    staged: Any = None
    checks: list[QualityCheck] = field(default_factory=list)
    bundle_path: Path | None = None
    html: Path | None = None
    kept: KeptFrames | None = None

    @property
    def staging(self) -> Path:
        """The chain's staging data root: its sessions and intermediate bundles."""
        return self.root / "staging" / self.base


def check(run: FullRun) -> None:
    """Refuse what would fail later, before anything is captured: the response scan's
    light and pitch, an unknown lamp spectrum, every scan's pitch against the streaks;
    and load the stages' procedures."""
    rig, procedure = run.rig, run.procedure
    desc = rig.description
    response_cfg = procedure["response"]
    run.response_pitch = scan_pitch(desc, response_cfg.get("pitch_px"))
    check_scan(rig, "white", response_cfg["light"], run.response_pitch)
    response_source(desc)  # the lamp's spectrum must be known before capturing
    # Every spacing a procedure leaves null is derived from the rig's optics here.
    stages = {
        kind: plan(_stage_procedure(kind, procedure[key]), desc)
        for kind, key, plan in (
            ("spectral_calibration", "spectral_procedure", planned_spectral),
            ("guide_registration", "guide_procedure", planned_guide),
            ("macbeth_validation", "macbeth_procedure", planned_macbeth),
        )
    }
    # Every plan of the chain, before anything is captured: a streak too long for a pitch,
    # or a guide stride that does not divide its pitch, would otherwise fail only at the
    # stage that uses it.
    check_lamp_pitch(desc, stages["spectral_calibration"])
    guide_scan = stages["guide_registration"]["scan"]
    check_stride(guide_scan["pitch_px"], guide_scan["stride_px"])
    for what, stage in (
        ("guide scan", stages["guide_registration"]),
        ("Macbeth scan", stages["macbeth_validation"]),
    ):
        check_scan_pitch(desc, tuple(stage["scan"]["pitch_px"]), what)
    macbeth = stages["macbeth_validation"]
    stages["macbeth_validation"] = with_changes(
        macbeth,
        white_reference={
            **macbeth["white_reference"],
            "source": procedure["macbeth_white_reference"],
        },
    )
    run.stage_procedures = stages


def spectral(run: FullRun) -> None:
    """The spectral calibration (its bundle staged)."""
    run.spectral = run_spectral_calibration(
        run.rig, run.stage_procedures["spectral_calibration"], session_id=f"{run.base}-spectral",
        data=run.staging, progress=run.progress, allow_failed=True,
    )  # fmt: skip
    release_memory()  # each stage's arrays go before the next one's come


def response(run: FullRun) -> None:
    """The radiometric response, on the spectral bundle (staged)."""
    cfg = run.procedure["response"]
    run.staged = load(
        run_response(
            run.rig, load(run.spectral.bundle_path), light=cfg["light"], every=int(cfg["every"]),
            reflectance=float(cfg["reflectance"]), pitch=run.response_pitch,
            max_frames=cfg.get("max_frames"), de00_sigma_max=cfg.get("de00_sigma_max"),
            sigma_max=cfg.get("sigma_max"),
            session_id=f"{run.base}-response",
            data=run.staging, progress=run.progress, allow_failed=True,
        )
    )  # fmt: skip
    release_memory()


def guide(run: FullRun) -> None:
    """The guide homography, on the response's bundle (staged)."""
    run.guide = run_guide_registration(
        run.rig, run.staged, run.stage_procedures["guide_registration"],
        session_id=f"{run.base}-guide", data=run.staging, progress=run.progress,
        allow_failed=True,
    )  # fmt: skip
    run.staged = load(run.guide.bundle_path)
    release_memory()


def macbeth(run: FullRun) -> None:
    """The Macbeth validation of the staged bundle, and its report."""
    proc = run.stage_procedures["macbeth_validation"]
    run.macbeth = run_macbeth(
        run.rig, run.staged, proc, session_id=f"{run.base}-macbeth", data=run.staging,
        progress=run.progress,
    )  # fmt: skip
    staged_at = f"the staged bundle {run.staged.path.relative_to(run.root).as_posix()} of this run"
    run.report = render_report(run.macbeth, run.staged, proc, scanned_from=staged_at)
    # The staged bundle carries the spectral, response and guide checks.
    run.checks = derived_checks(run.staged, "macbeth", run.macbeth.checks)


def publish(run: FullRun) -> None:
    """Publish one bundle with every model, check and figure and the Macbeth report (when
    every tolerance passed, or ``allow_failed``), and write the report beside it; else
    write the report of the unpublished bundle."""
    reports: dict[str, Any] = {f"spectral_{k}.png": v for k, v in run.spectral.figures.items()}
    reports.update({f"{k}.png": v for k, v in run.guide.figures.items()})  # named guide_*
    # Rendered against the published manifest, so the report names its own version; it
    # links the figures published beside it.
    figures = {name: name for name in reports}
    reports.update(
        {
            "macbeth_report.html": partial(run.report.html, figure_links=figures),
            "macbeth_report.json": run.report.json,
        }
    )
    chart = Session.open(run.macbeth.settings["chart_session"], data=run.staging)
    if all(c.passed for c in run.checks) or run.allow_failed:
        run.bundle_path = publish_derived(
            run.staged,
            stage="macbeth",
            rig=run.rig.description,
            checks=run.macbeth.checks,
            residuals=run.macbeth.summary(),
            procedure={  # the response and guide procedures come with the staged bundle
                "full_calibration": dict(run.procedure),
                "spectral_calibration": run.stage_procedures["spectral_calibration"],
                "macbeth_validation": run.stage_procedures["macbeth_validation"],
            },
            inputs=[{"id": chart.id, "sha256": chart.sha256(), "kind": "session"}],
            reports=reports,
            allow_failed=run.allow_failed,
            data=run.root,
        )
        run.report_dir.mkdir(parents=True, exist_ok=True)
        published = run.bundle_path / "report"
        # The copy beside the run links the same figures, in the bundle's folder.
        links = figure_links(figures, published, run.report_dir)
        manifest = json.loads((run.bundle_path / "manifest.json").read_text(encoding="utf-8"))
        manifest.pop("reports", None)  # as the bundle's own copy was rendered
        copy = run.report.html(manifest, figure_links=links)
        atomic_write_bytes(run.report_dir / "macbeth_report.html", copy.encode(), overwrite=False)
        raw = (published / "macbeth_report.json").read_bytes()
        atomic_write_bytes(run.report_dir / "macbeth_report.json", raw, overwrite=False)
        run.html = run.report_dir / "macbeth_report.html"
    else:
        unpublished = {
            **thaw(run.staged.manifest),
            "version": None,
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
            "passed": False,
            "quality": {"checks": [c.to_manifest() for c in run.checks]},
        }
        run.html, _ = run.report.write(run.report_dir, unpublished)


def keep(run: FullRun) -> None:
    """Drop the raw frames the procedure's ``keep`` does not keep, once the bundle is
    published (until then a re-run resumes from them)."""
    policy = run.procedure.get("keep", "all") if run.bundle_path else "all"
    run.kept = keep_frames(run.staging, run.base, policy)


#: The calibration chain's steps, in order.
STEPS = {
    "check": check,
    "spectral": spectral,
    "response": response,
    "guide": guide,
    "macbeth": macbeth,
    "publish": publish,
    "keep": keep,
}


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
    Not run here (it drives a bench and stores its frames)::

        from sassi_bench import open_rig
        result = run_full_calibration(
            open_rig("sim"), load_procedure("full_calibration"))
        result.passed, result.bundle_path
        # (True, PosixPath('calib_data/sim/v0001'))
    """
    base = session_id or "full-" + datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
    root = data_root(data)
    report_dir = Path(out) if out is not None else root / "reports" / base
    run = FullRun(rig, procedure, base, root, report_dir, progress, allow_failed)
    run_steps(STEPS, run, procedure="calibrate")
    stages = {
        "spectral": run.spectral, "guide": run.guide, "macbeth": run.macbeth,
        "staging": run.staging,
    }  # fmt: skip
    return FullCalibration(run.checks, run.bundle_path, run.html, stages, run.kept)
