"""A batch end to end: resolve the inputs once, run one task per session, write the summary."""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from sassi_bench.batch.engine import DASHBOARD_ADDRESS, batch_client, run_tasks
from sassi_bench.batch.summary import summary_csv, summary_html
from sassi_bench.batch.tasks import Kind, SessionResult, TaskSpec
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.paths import data_root

__all__ = ["BatchResult", "check_out", "run_batch"]


@dataclass
class BatchResult:
    """The sessions of a batch and where its summary went."""

    kind: str
    results: list[SessionResult]
    seconds: float
    dashboard: str | None
    summary_csv: Path | None = None
    summary_html: Path | None = None
    workers: int = 0
    facts: list[str] = field(default_factory=list)

    @property
    def failed(self) -> list[SessionResult]:
        """The sessions that failed, with their errors."""
        return [r for r in self.results if r.status == "failed"]


def check_out(out: str | os.PathLike[str]) -> Path:
    """The output folder as an absolute path (not created here); refused when it is a file.

    Parameters
    ----------
    out
        The ``--out`` folder of a batch.

    Returns
    -------
    pathlib.Path
        ``out`` resolved to an absolute path.

    Raises
    ------
    ProcedureError
        If ``out`` is an existing file.

    Examples
    --------
    >>> check_out("/tmp/cubes").as_posix()
    '/tmp/cubes'
    """
    path = Path(out).resolve()
    if path.exists() and not path.is_dir():
        raise ProcedureError(
            step_error("batch output", f"{path} is a file", "give a folder for --out")
        )
    return path


def run_batch(
    kind: Kind,
    sessions: Sequence[str],
    bundle: CalibrationBundle,
    out: str | os.PathLike[str],
    *,
    data: str | os.PathLike[str] | None = None,
    scheduler: str | None = None,
    workers: int | None = None,
    roi: Sequence[int] | None = None,
    procedure: Mapping[str, Any] | None = None,
    corners: Sequence[Sequence[float]] | None = None,
    progress: bool = True,
    client=None,
    dashboard: str | None = DASHBOARD_ADDRESS,
) -> BatchResult:
    """Assemble (or validate) ``sessions`` with ``bundle``, one dask task per session.

    Parameters
    ----------
    kind
        ``assemble``: write ``<out>/<session>.nc`` (the cube ``sassi-bench scan`` writes).
        ``validate``: Macbeth CIEDE2000 of a ColorChecker scan with the chart's white patch
        as the white reference, written to ``<out>/<session>.macbeth.json``.
    sessions
        Session ids under ``<data>/sessions`` (see :func:`~sassi_bench.batch.select_sessions`).
    bundle
        The calibration bundle; workers load it from its folder.
    out
        Output folder, on the store every worker sees; the summary goes there too.
    data
        Data root, on the store every worker sees.
    scheduler
        ``tcp://host:port`` of a running scheduler; None starts a local cluster.
    workers
        Worker processes of the local cluster (default: one per CPU).
    roi
        Optional SLM region to assemble.
    procedure
        The ``macbeth_validation`` procedure (validate).
    corners
        SLM (u, v) centres of patches 1, 6, 24 and 19 (validate; default: detect the chart).
    progress
        Progress bar and the dashboard's address on the terminal.
    client
        An open ``distributed.Client`` to use instead (notebooks, tests).
    dashboard
        ``host:port`` of a local cluster's dashboard (default: this machine only), or
        None for none.

    Returns
    -------
    BatchResult

    Examples
    --------
    Not run here (it needs captured sessions)::

        from sassi_bench.bundle import load
        batch = run_batch("assemble", ["scan-1", "scan-2"], load(rig="sim"),
                          "cubes")
        [r.status for r in batch.results]
        # ['done', 'done']
    """
    if kind == "validate" and procedure is None:
        from sassi_bench.procedure import load_procedure

        procedure = load_procedure("macbeth_validation")
    folder = check_out(out)
    folder.mkdir(parents=True, exist_ok=True)
    root = str(data_root(data).resolve())
    fixed = tuple((float(u), float(v)) for u, v in corners) if corners is not None else None
    bundle_path = str(Path(bundle.path).resolve())
    specs = [
        TaskSpec(kind, s, root, bundle_path, str(folder), roi, procedure, fixed) for s in sessions
    ]
    start = time.perf_counter()
    if client is None:
        with batch_client(scheduler, workers, dashboard) as own:
            return _run(kind, specs, own, folder, bundle, progress, start)
    return _run(kind, specs, client, folder, bundle, progress, start)


def _run(kind, specs, client, folder: Path, bundle, progress: bool, start: float) -> BatchResult:
    dashboard = client.dashboard_link
    workers = len(client.scheduler_info(n_workers=-1)["workers"])
    if progress:
        print(f"{len(specs)} sessions on {workers} workers; dashboard: {dashboard}")
    results = run_tasks(client, specs, progress=progress)
    seconds = time.perf_counter() - start
    facts = [
        f"bundle {bundle.rig_name}/{bundle.version} ({bundle.path})",
        f"data root {specs[0].data}" if specs else "no sessions",
        f"outputs in {folder}",
        f"{workers} workers ({client.scheduler.address}); {seconds:.1f} s wall time",
    ]
    batch = BatchResult(kind, results, seconds, dashboard, workers=workers, facts=facts)
    batch.summary_csv = summary_csv(results, folder / f"batch-{kind}.csv")
    batch.summary_html = summary_html(
        results, folder / f"batch-{kind}.html", title=f"Batch {kind}", facts=facts
    )
    return batch
