"""Nothing a batch starts listens beyond this machine unless asked: the local cluster's
scheduler, workers, nannies and dashboard bind the loopback address."""

from __future__ import annotations

import ipaddress

import psutil
import pytest

from sassi_bench.batch import engine
from sassi_bench.batch.engine import batch_client, check_dashboard, run_tasks
from sassi_bench.batch.tasks import SessionResult, TaskSpec
from sassi_bench.commands import batch as batch_command
from sassi_bench.errors import ProcedureError


def _listening(processes) -> set[tuple[int, str, int]]:
    """(pid, address, port) of every TCP socket the processes listen on."""
    found = set()
    for process in processes:
        try:
            connections = process.net_connections(kind="inet")
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            continue
        for c in connections:
            if c.status == psutil.CONN_LISTEN:
                found.add((process.pid, c.laddr.ip, c.laddr.port))
    return found


def _ours() -> list[psutil.Process]:
    me = psutil.Process()
    return [me, *me.children(recursive=True)]


def _echo(spec: TaskSpec) -> SessionResult:
    return SessionResult(spec.session, "done")


def test_a_local_batch_listens_on_loopback_only():
    before = _listening(_ours())
    with batch_client(workers=1) as client:
        specs = [TaskSpec("assemble", f"s{k}", "/data", "/bundle", "/out") for k in range(2)]
        assert [r.status for r in run_tasks(client, specs, progress=False, task=_echo)] == [
            "done",
            "done",
        ]
        opened = _listening(_ours()) - before
        link = client.dashboard_link
    # the scheduler, the worker, its nanny, the dashboard: all there, and all loopback
    assert len({pid for pid, _, _ in opened}) >= 2, opened
    outside = [(pid, ip, port) for pid, ip, port in opened
               if not ipaddress.ip_address(ip).is_loopback]  # fmt: skip
    assert not outside, f"listening beyond this machine: {outside}"
    assert any(port == int(link.split(":")[2].split("/")[0]) for _, _, port in opened)
    assert link.startswith("http://127.0.0.1:")


def test_the_dashboard_opens_beyond_loopback_only_when_asked():
    assert batch_command.DASHBOARD_ADDRESS == engine.DASHBOARD_ADDRESS == "127.0.0.1:0"
    assert check_dashboard("0.0.0.0:8787") == "0.0.0.0:8787"
    assert check_dashboard("None") is None
    for bad in ("8787", "http://0.0.0.0:8787", "host:99999"):
        with pytest.raises(ProcedureError, match=r"batch dashboard: .* is not host:port"):
            check_dashboard(bad)
