"""Batches on a two-worker local cluster: the cubes of the serial path, bit for bit;
re-runs skip finished outputs; a corrupt session fails alone; a killed worker's task runs
again elsewhere."""

from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import threading
import time

import numpy as np
import pytest
import xarray as xr

from sassi_bench.acquire.session import Session
from sassi_bench.batch import run_batch
from sassi_bench.batch.tasks import scan_dataset


@pytest.fixture(scope="module")
def serial(scans):
    """The serial path's cube of every session (``sassi-bench scan``'s dataset)."""
    data, bundle, ids = scans
    return {s: scan_dataset(Session.open(s, data=data), bundle) for s in ids}


@pytest.fixture(scope="module")
def first_batch(scans, client, tmp_path_factory):
    data, bundle, ids = scans
    out = tmp_path_factory.mktemp("cubes")
    return out, run_batch("assemble", ids, bundle, out, data=data, client=client, progress=False)


def _same(path, expected: xr.Dataset) -> bool:
    with xr.open_dataset(path) as got:
        return all(
            got[name].dtype == expected[name].dtype
            and np.array_equal(got[name].values, expected[name].values)
            for name in ("radiance", "quality")
        )


def test_batch_cubes_equal_the_serial_path_bit_for_bit(first_batch, serial):
    _, batch = first_batch
    assert [r.status for r in batch.results] == ["done"] * 3, batch.failed
    for result in batch.results:
        assert result.frames == 20
        assert _same(result.output, serial[result.session])
    assert batch.workers == 2 and batch.dashboard.startswith("http")


def test_summary_lists_every_session_in_csv_and_html(first_batch):
    _, batch = first_batch
    with open(batch.summary_csv) as stream:
        rows = list(csv.DictReader(stream))
    assert [r["session"] for r in rows] == ["scan-colorchecker", "scan-white", "scan-pcb"]
    assert all(r["status"] == "done" and r["frames"] == "20" for r in rows)
    assert all(float(r["time_s"]) > 0 for r in rows)
    page = batch.summary_html.read_text()
    assert page.count("<tr>") == 4 and "3 sessions: 3 done, 0 skipped, 0 failed" in page


def test_a_rerun_skips_finished_cubes_and_redoes_a_damaged_one(first_batch, scans, client):
    data, bundle, ids = scans
    out, _ = first_batch
    damaged = out / "scan-white.nc"
    with open(damaged, "ab") as stream:
        stream.write(b"\0")
    again = run_batch("assemble", ids, bundle, out, data=data, client=client, progress=False)
    status = {r.session: r.status for r in again.results}
    assert status == {"scan-colorchecker": "skipped", "scan-white": "done", "scan-pcb": "skipped"}
    record = json.loads((out / "scan-white.nc.json").read_text())
    assert record["inputs"]["session_sha256"] == Session.open("scan-white", data=data).sha256()
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def test_outputs_of_other_inputs_are_not_overwritten(first_batch, scans, client):
    data, bundle, _ = scans
    out, _ = first_batch
    before = (out / "scan-pcb.nc").read_bytes()
    batch = run_batch(
        "assemble", ["scan-pcb"], bundle, out, data=data, client=client, progress=False,
        roi=(100, 100, 200, 300),
    )  # fmt: skip
    assert batch.results[0].status == "failed"
    assert "made from other inputs" in batch.results[0].error
    assert (out / "scan-pcb.nc").read_bytes() == before


def test_a_corrupt_session_fails_alone(scans, client, serial, tmp_path):
    _, bundle, ids = scans
    data = tmp_path / "data"
    shutil.copytree(scans[0], data)
    broken = data / "sessions" / "scan-broken"
    shutil.copytree(data / "sessions" / "scan-pcb", broken)
    frames = broken / "frames.zarr"
    chunks = sorted(
        p for p in frames.rglob("*") if p.is_file() and "c" in p.relative_to(frames).parts
    )
    chunks[len(chunks) // 2].write_bytes(b"not a compressed frame")
    batch = run_batch(
        "assemble", [ids[0], "scan-broken", ids[2]], bundle, tmp_path / "out", data=data,
        client=client, progress=False,
    )  # fmt: skip
    status = {r.session: r.status for r in batch.results}
    assert status == {ids[0]: "done", "scan-broken": "failed", ids[2]: "done"}
    assert batch.failed[0].error and not (tmp_path / "out" / "scan-broken.nc").exists()
    assert batch.failed[0].frames == 20
    assert _same(tmp_path / "out" / f"{ids[2]}.nc", serial[ids[2]])
    with open(batch.summary_csv) as stream:
        row = next(r for r in csv.DictReader(stream) if r["session"] == "scan-broken")
    assert row["status"] == "failed" and row["error"] == batch.failed[0].error


def test_a_killed_worker_s_task_runs_again_on_another(scans, client, serial, tmp_path):
    """SIGKILL to the worker process that is assembling a session, mid-task."""
    data, bundle, ids = scans
    pids = client.run(os.getpid)
    done: dict = {}
    runner = threading.Thread(
        target=lambda: done.update(
            batch=run_batch("assemble", ids, bundle, tmp_path, data=data, client=client,
                            progress=False)
        )
    )  # fmt: skip
    runner.start()
    busy: dict = {}
    deadline = time.monotonic() + 60
    while not busy and time.monotonic() < deadline:
        busy = {w: keys for w, keys in client.processing().items() if keys}
        time.sleep(0.01)
    victim, keys = next(iter(busy.items()))
    os.kill(pids[victim], signal.SIGKILL)
    runner.join(timeout=120)
    batch = done["batch"]
    assert [r.status for r in batch.results] == ["done"] * 3, batch.failed
    for result in batch.results:
        assert _same(result.output, serial[result.session])
    killed = {k.rsplit("-", 1)[0].removeprefix("assemble-") for k in keys}
    assert killed & set(ids), keys
    assert pids[victim] not in client.run(os.getpid).values()
