"""What one task does with one session, on whichever worker runs it.

A task gets paths, not objects: the data root and the bundle folder are resolved once by
the client, and every worker reads them from the shared store (the same paths must be
visible on every machine of the cluster). It opens the session and loads (and verifies)
the bundle itself, so nothing large crosses the network.
"""

from __future__ import annotations

import json
import time
import traceback
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import xarray as xr

from sassi_bench.acquire.scan_plans import Roi
from sassi_bench.acquire.session import Session
from sassi_bench.batch.outputs import finished, write_atomic
from sassi_bench.bundle import CalibrationBundle, load
from sassi_bench.bundle.integrity import sha256_file
from sassi_bench.reduce.scan import ScanRun, assemble_scan
from sassi_bench.spectra.cube_io import write_netcdf
from sassi_bench.validate.chart import validate_scans

__all__ = ["SessionResult", "TaskSpec", "bundle_sha256", "output_path", "run_task", "scan_dataset"]

Kind = Literal["assemble", "validate"]

#: Output file of each kind, after the session id.
SUFFIXES: dict[str, str] = {"assemble": ".nc", "validate": ".macbeth.json"}


@dataclass(frozen=True)
class TaskSpec:
    """One session's task: plain values only, so it travels to any worker.

    Attributes
    ----------
    kind
        ``assemble`` (write the cube) or ``validate`` (Macbeth dE00 of a chart scan).
    session
        Session id under ``<data>/sessions``.
    data
        Absolute data root, the same on every worker.
    bundle
        Absolute bundle folder.
    out
        Absolute output folder.
    roi
        Optional SLM region (row0, col0, row1, col1) to assemble.
    procedure
        The Macbeth procedure (validate only).
    corners
        SLM (u, v) centres of patches 1, 6, 24 and 19 instead of detecting the chart
        (validate only; one chart placement for the whole batch).
    threads
        Threads of the assembly inside the task (one per core the task has).
    """

    kind: Kind
    session: str
    data: str
    bundle: str
    out: str
    roi: Roi | None = None
    procedure: Mapping[str, Any] | None = None
    corners: tuple[tuple[float, float], ...] | None = None
    threads: int = 1


@dataclass
class SessionResult:
    """What became of one session: a row of the batch summary.

    ``status`` is ``done``, ``skipped`` (its output was already finished) or ``failed``
    (``error`` says why; ``detail`` holds the traceback).
    """

    session: str
    status: str
    frames: int = 0
    seconds: float = 0.0
    output: str = ""
    metrics: dict[str, float] = field(default_factory=dict)
    error: str = ""
    detail: str = ""


def output_path(spec: TaskSpec) -> Path:
    """Where a task writes its result.

    Parameters
    ----------
    spec
        The task.

    Returns
    -------
    pathlib.Path
        ``<out>/<session>.nc`` for ``assemble``, ``<out>/<session>.macbeth.json`` for
        ``validate``.

    Examples
    --------
    >>> output_path(TaskSpec("assemble", "scan-1", "/d", "/b", "/out")).as_posix()
    '/out/scan-1.nc'
    """
    return Path(spec.out) / f"{spec.session}{SUFFIXES[spec.kind]}"


def bundle_sha256(bundle: CalibrationBundle) -> str:
    """SHA-256 of the bundle's manifest (which holds the hash of every array).

    Parameters
    ----------
    bundle
        A loaded bundle.

    Returns
    -------
    str
        64 hex digits.

    Examples
    --------
    >>> len(bundle_sha256(bundle))
    64
    """
    return sha256_file(Path(bundle.path) / "manifest.json")


def scan_dataset(
    session: Session,
    bundle: CalibrationBundle,
    *,
    roi: Roi | None = None,
    threads: int | None = None,
) -> xr.Dataset:
    """A scan session's cube as written by ``sassi-bench scan`` and by batches.

    Parameters
    ----------
    session
        A pinhole-scan session.
    bundle
        The bundle to assemble with.
    roi
        Part of the SLM to assemble; all of it by default.
    threads
        Threads of the assembly.

    Returns
    -------
    xarray.Dataset
        The cube (dims y, x, wavelength) with its quality mask, units and provenance.

    Examples
    --------
    Not run here (it needs captured sessions)::

        ds = scan_dataset(Session.open("scan-1"), load(rig="sim"))
    """
    scan = assemble_scan(session, bundle, roi=roi, progress=False, workers=threads)
    return ScanRun(scan, bundle.response is not None, session, bundle).dataset()


def _inputs(spec: TaskSpec, session: Session, bundle: CalibrationBundle) -> dict[str, Any]:
    return {
        "session": session.id,
        "session_sha256": session.sha256(),
        "bundle": f"{bundle.rig_name}/{bundle.version}",
        "bundle_sha256": bundle_sha256(bundle),
        "roi": list(spec.roi) if spec.roi else None,
        "procedure": dict(spec.procedure) if spec.kind == "validate" and spec.procedure else None,
        "corners": [list(c) for c in spec.corners] if spec.corners else None,
    }


def _macbeth(spec: TaskSpec, session: Session, bundle: CalibrationBundle) -> dict[str, Any]:
    """Validate a chart scan alone: the chart's white patch is the white reference."""
    assert spec.procedure is not None
    procedure = {
        **spec.procedure,
        "white_reference": {**spec.procedure["white_reference"], "source": "patch"},
    }
    scan = assemble_scan(
        session, bundle, roi=spec.roi, keep_raw=True, progress=False, workers=spec.threads
    )
    result = validate_scans(
        scan, bundle, procedure, corners=spec.corners, settings={"chart_session": session.id}
    )
    return {**result.summary(), "passed": bool(result.passed)}


def _frames(session: Session) -> int:
    return sum(1 for i in session.plan.select(role="pinholes") if i in session.completed)


def run_task(spec: TaskSpec) -> SessionResult:
    """Run one session's task; every error is caught and returned with the session's id.

    An output already finished from the same inputs is skipped (see
    :func:`~sassi_bench.batch.outputs.finished`).

    Parameters
    ----------
    spec
        The task: its kind, session, data root, bundle and output folder.

    Returns
    -------
    SessionResult
        ``done``, ``skipped`` or ``failed`` (with the error and its traceback).

    Examples
    --------
    >>> run_task(TaskSpec("assemble", "scan-1", "/data", "/data/sim/v0001", "/out")).status
    'failed'
    """
    start = time.perf_counter()
    output = output_path(spec)
    frames = 0
    try:
        session = Session.open(spec.session, data=spec.data)
        frames = _frames(session)
        bundle = load(spec.bundle)
        inputs = _inputs(spec, session, bundle)
        status, metrics = "skipped", {}
        if finished(output, inputs):
            if spec.kind == "validate":
                metrics = json.loads(output.read_bytes())["metrics"]
        elif spec.kind == "assemble":
            status, ds = "done", scan_dataset(session, bundle, roi=spec.roi, threads=spec.threads)
            write_atomic(output, lambda path: write_netcdf(ds, path), inputs)
        else:
            status, metrics = "done", _macbeth(spec, session, bundle)
            body = json.dumps({"session": spec.session, "metrics": metrics}, indent=1) + "\n"
            write_atomic(output, lambda path: path.write_text(body), inputs)
        seconds = time.perf_counter() - start
        return SessionResult(spec.session, status, frames, seconds, str(output), metrics)
    except Exception as exc:  # reported by session id; the batch goes on
        return SessionResult(
            spec.session,
            "failed",
            frames,
            time.perf_counter() - start,
            error=f"{type(exc).__name__}: {exc}",
            detail=traceback.format_exc(),
        )
