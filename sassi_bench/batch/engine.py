"""The distributed engine: a client of a lab's scheduler or of a local cluster, and the
loop that submits one task per session and gathers them as they finish.

Failure handling is dask.distributed's own: when a worker dies (killed, out of memory,
machine lost) the scheduler hands its running tasks to other workers (a nanny restarts a
local worker); a task whose workers die ``distributed.scheduler.allowed-failures`` times
(default 3) ends in ``KilledWorker``, which is reported for that session like any other
error. Errors inside a task are caught by the task (:func:`~sassi_bench.batch.tasks.run_task`)
and are not retried: reading a corrupt session again gives the same error.
"""

from __future__ import annotations

import logging
import os
import re
import uuid
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager

from tqdm.auto import tqdm

from sassi_bench.batch.tasks import SessionResult, TaskSpec, run_task
from sassi_bench.errors import ProcedureError, step_error

__all__ = [
    "DASHBOARD_ADDRESS",
    "LOCAL_HOST",
    "batch_client",
    "check_dashboard",
    "check_scheduler",
    "default_workers",
    "run_tasks",
]

_ADDRESS = re.compile(r"^(tcp|tls|ws|wss)://[^\s:/]+:\d{1,5}$")
_HOST_PORT = re.compile(r"^(?P<host>[^\s:/]*|\[[0-9A-Fa-f:]+\]):(?P<port>\d{1,5})$")

#: Where the local cluster's scheduler, workers and nannies listen: this machine only.
LOCAL_HOST = "127.0.0.1"
#: Where the local cluster's dashboard listens unless asked otherwise: this machine only,
#: any free port (several people share a machine). The dashboard shows task names, paths,
#: logs and profiles: opening it to the lab's network is a choice (``--dashboard``).
DASHBOARD_ADDRESS = f"{LOCAL_HOST}:0"

#: Seconds to wait for a lab's scheduler to answer.
CONNECT_TIMEOUT_S = 20


def check_scheduler(address: str) -> str:
    """Refuse a scheduler address that is not ``protocol://host:port``.

    Parameters
    ----------
    address
        A dask scheduler address; the protocol is ``tcp``, ``tls``, ``ws`` or ``wss``.

    Returns
    -------
    str
        ``address``, unchanged.

    Raises
    ------
    ProcedureError
        If ``address`` is not of that form.

    Examples
    --------
    >>> check_scheduler("tcp://10.0.0.5:8786")
    'tcp://10.0.0.5:8786'
    >>> check_scheduler("10.0.0.5")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    ProcedureError: batch scheduler: '10.0.0.5' is not a scheduler address...
    """
    if not _ADDRESS.match(address):
        raise ProcedureError(
            step_error(
                "batch scheduler",
                f"{address!r} is not a scheduler address",
                "give it as tcp://host:port (what `dask scheduler` prints), or leave "
                "--scheduler out to run on this machine",
            )
        )
    return address


def check_dashboard(address: str) -> str | None:
    """The dashboard address ``--dashboard`` gives: ``host:port`` (port 0: any free one),
    or None for ``none`` (no dashboard).

    Parameters
    ----------
    address
        ``127.0.0.1:0`` (the default: this machine only), ``0.0.0.0:8787`` (every
        interface: anyone on the network can read it), ``none``.

    Raises
    ------
    ProcedureError
        If ``address`` is neither.

    Examples
    --------
    >>> check_dashboard("127.0.0.1:0"), check_dashboard("none")
    ('127.0.0.1:0', None)
    >>> check_dashboard("8787")  # doctest: +IGNORE_EXCEPTION_DETAIL
    Traceback (most recent call last):
    ProcedureError: batch dashboard: '8787' is not host:port...
    """
    if address.strip().lower() == "none":
        return None
    match = _HOST_PORT.match(address.strip())
    if match is None or int(match["port"]) > 65535:
        raise ProcedureError(
            step_error(
                "batch dashboard",
                f"{address!r} is not host:port",
                f"give e.g. {DASHBOARD_ADDRESS} (this machine only, any free port), "
                "0.0.0.0:8787 to open it to the network on purpose, or none",
            )
        )
    return address.strip()


def default_workers() -> int:
    """Workers of the local cluster: one single-threaded process per CPU available here.

    Returns
    -------
    int
        The CPUs this process may run on (its affinity), at least 1.

    Examples
    --------
    >>> default_workers() >= 1
    True
    """
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # pragma: no cover (not Linux)
        return max(1, os.cpu_count() or 1)


@contextmanager
def batch_client(
    scheduler: str | None = None,
    workers: int | None = None,
    dashboard: str | None = DASHBOARD_ADDRESS,
) -> Iterator:
    """A ``distributed.Client``: of the scheduler at ``scheduler``, else of a new
    ``LocalCluster`` of ``workers`` single-threaded worker processes (default: one per
    CPU), closed on exit.

    Worker processes (not threads): assembly holds the GIL in parts (Python between
    compiled passes, NetCDF writes), and a process can be killed alone. Everything the
    local cluster serves listens on the loopback address only (scheduler, workers,
    nannies and, unless ``dashboard`` says otherwise, the dashboard).

    Parameters
    ----------
    scheduler
        Address of a running scheduler (``tcp://host:port``), or None for a local cluster.
    workers
        Worker processes of the local cluster (ignored with ``scheduler``).
    dashboard
        ``host:port`` of the local cluster's dashboard (default: this machine only, any
        free port; see :func:`check_dashboard`), or None for none.

    Yields
    ------
    distributed.Client
        Connected; closed (and the local cluster shut down) on exit.

    Raises
    ------
    ProcedureError
        For a malformed address, a scheduler that does not answer, or fewer than 1 worker.

    Examples
    --------
    Not run here (it needs captured sessions)::

        with batch_client(workers=2) as client:
            print(client.dashboard_link)
    """
    from distributed import Client, LocalCluster

    if scheduler is not None:
        check_scheduler(scheduler)
        try:
            client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
        except (OSError, TimeoutError) as exc:
            raise ProcedureError(
                step_error(
                    "batch scheduler",
                    f"no scheduler answered at {scheduler} ({exc})",
                    "start it (dask scheduler) or check the address and firewall",
                )
            ) from exc
        with client:
            yield client
        return
    if workers is not None and workers < 1:
        raise ProcedureError(step_error("batch workers", f"{workers} workers", "give 1 or more"))
    cluster = LocalCluster(
        n_workers=workers or default_workers(),
        threads_per_worker=1,
        processes=True,
        host=LOCAL_HOST,
        dashboard_address=dashboard,
        silence_logs=logging.ERROR,
    )
    with cluster, Client(cluster) as client:
        yield client


def run_tasks(
    client,
    specs: Sequence[TaskSpec],
    *,
    progress: bool = True,
    task: Callable[[TaskSpec], SessionResult] = run_task,
) -> list[SessionResult]:
    """Submit one task per spec and gather the results as they finish (in spec order).

    Parameters
    ----------
    client
        A ``distributed.Client`` (see :func:`batch_client`).
    specs
        One task per session.
    progress
        Show a progress bar (and each failure as it comes).
    task
        The function each worker runs on a spec.

    Returns
    -------
    list of SessionResult
        One per spec, in the order of ``specs``; a task lost with its workers (e.g.
        ``KilledWorker``) is a ``"failed"`` result naming the exception.

    Examples
    --------
    Not run here (it needs captured sessions)::

        with batch_client(workers=2) as client:
            results = run_tasks(client, specs)
    """
    from distributed import as_completed

    run = uuid.uuid4().hex[:8]  # a fresh key per run: a scheduler may still hold the last
    futures = {
        client.submit(task, spec, key=f"{spec.kind}-{spec.session}-{run}", pure=False): spec
        for spec in specs
    }
    results: dict[str, SessionResult] = {}
    bar = tqdm(total=len(futures), desc="sessions", unit="session", disable=not progress)
    with bar:
        for future in as_completed(futures):
            spec = futures[future]
            try:
                result = future.result()
            except Exception as exc:  # KilledWorker, a lost scheduler: this session alone
                result = SessionResult(spec.session, "failed", error=f"{type(exc).__name__}: {exc}")
            results[spec.session] = result
            bar.update()
            if result.status == "failed":
                bar.write(f"{spec.session}: failed: {result.error}")
    return [results[spec.session] for spec in specs]
