"""Publishing: quality gate, atomic never-overwriting versions, concurrency, input checks."""

from __future__ import annotations

import json
import multiprocessing
import os
import time
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.bundle import BundleError, BundleQualityError, load, publish, writer
from sassi_bench.bundle.jsonio import thaw
from sassi_bench.bundle.layout import LATEST_LOCK_NAME


def test_failed_quality_is_refused_without_override(data_root: Path, synthetic):
    with pytest.raises(BundleQualityError) as info:
        synthetic.publish_synthetic(data_root, quality=synthetic.failing_quality())
    message = str(info.value)
    assert "dispersion_rms = 0.9 px (tolerance <= 0.25 px)" in message
    assert "allow_failed=True" in message
    assert not (data_root / "sim").exists() or not any((data_root / "sim").iterdir())


def test_failed_quality_published_with_override_is_marked(data_root: Path, synthetic):
    path = synthetic.publish_synthetic(
        data_root, quality=synthetic.failing_quality(), allow_failed=True
    )
    bundle = load(path)
    assert bundle.passed is False and bundle.override is True
    manifest = json.loads((path / "manifest.json").read_text())
    assert manifest["passed"] is False and manifest["override"] is True
    failed = [c["name"] for c in manifest["quality"]["checks"] if not c["passed"]]
    assert failed == ["dispersion_rms"]


def test_allow_failed_on_a_passing_bundle_is_not_an_override(data_root: Path, synthetic):
    bundle = load(synthetic.publish_synthetic(data_root, allow_failed=True))
    assert bundle.passed is True and bundle.override is False


def test_versions_increment_and_never_overwrite(data_root: Path, synthetic):
    paths = [synthetic.publish_synthetic(data_root) for _ in range(3)]
    assert [p.name for p in paths] == ["v0001", "v0002", "v0003"]
    assert [load(p).parent for p in paths] == [None, "v0001", "v0002"]
    before = (paths[0] / "manifest.json").read_bytes()
    synthetic.publish_synthetic(data_root)
    assert (paths[0] / "manifest.json").read_bytes() == before
    assert (data_root / "sim" / "LATEST").read_text().strip() == "v0004"


def test_retries_when_another_process_took_the_number(data_root: Path, synthetic, monkeypatch):
    first = synthetic.publish_synthetic(data_root)
    real_versions = writer.versions
    calls = {"n": 0}

    def stale_scan(folder):
        # The first scan misses v0001, as if it had been published after we looked.
        calls["n"] += 1
        return [] if calls["n"] == 1 else real_versions(folder)

    monkeypatch.setattr(writer, "versions", stale_scan)
    second = synthetic.publish_synthetic(data_root)
    assert second.name == "v0002" and calls["n"] >= 2
    assert load(second).version == "v0002" and load(first).version == "v0001"


def test_rename_collision_is_retried(data_root: Path, synthetic, monkeypatch):
    real_rename = os.rename
    seen = []

    def racing_rename(src, dst):
        # Another publisher creates the target just before our rename.
        if not seen:
            Path(dst).mkdir()
            (Path(dst) / "manifest.json").write_text("{}")
        seen.append(Path(dst).name)
        return real_rename(src, dst)

    monkeypatch.setattr(writer.os, "rename", racing_rename)
    path = synthetic.publish_synthetic(data_root)
    assert seen == ["v0001", "v0002"]
    assert path.name == "v0002"
    assert (data_root / "sim" / "v0001" / "manifest.json").read_text() == "{}"  # untouched


def _publish_from_template(template: str, data: str, barrier) -> str:
    """Worker: republish the models of a template bundle (only paths cross processes)."""
    bundle = load(template)
    barrier.wait(timeout=30)
    path = publish(
        bundle.models,
        rig=thaw(bundle.manifest["rig"]),
        quality=thaw(bundle.manifest["quality"]),
        procedure={"worker": os.getpid()},
        data=data,
    )
    return str(path)


def _worker(template: str, data: str, barrier, results) -> None:
    try:
        results.put(_publish_from_template(template, data, barrier))
    except Exception as exc:  # report, do not hang the parent
        results.put(f"ERROR {type(exc).__name__}: {exc}")


def test_concurrent_publishers_get_distinct_intact_versions(tmp_path: Path, synthetic):
    template = synthetic.publish_synthetic(tmp_path / "template")
    data = tmp_path / "shared"
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    n = 4
    barrier = ctx.Barrier(n)
    results = ctx.Queue()
    procs = [
        ctx.Process(target=_worker, args=(str(template), str(data), barrier, results))
        for _ in range(n)
    ]
    for proc in procs:
        proc.start()
    outputs = [results.get(timeout=60) for _ in range(n)]
    for proc in procs:
        proc.join(timeout=30)
        assert proc.exitcode == 0
    assert not [o for o in outputs if o.startswith("ERROR")], outputs
    names = sorted(Path(o).name for o in outputs)
    assert names == ["v0001", "v0002", "v0003", "v0004"]
    pids = set()
    for name in names:
        bundle = load(data / "sim" / name)  # verifies every checksum
        pids.add(bundle.manifest["procedure"]["worker"])
    assert len(pids) == n
    # LATEST is compared and replaced under a lock: never a version older than the newest.
    assert (data / "sim" / "LATEST").read_text().strip() == names[-1]
    leftovers = [
        p.name
        for p in (data / "sim").iterdir()
        if p.name.startswith(".") and p.name != LATEST_LOCK_NAME
    ]
    assert leftovers == []


def test_latest_never_goes_backwards(data_root: Path, synthetic):
    synthetic.publish_synthetic(data_root)
    synthetic.publish_synthetic(data_root)
    from sassi_bench.bundle.layout import update_latest

    update_latest(data_root / "sim", "v0001")
    assert (data_root / "sim" / "LATEST").read_text().strip() == "v0002"


def test_object_and_string_arrays_are_refused(data_root: Path, synthetic):
    with pytest.raises(BundleError, match="dtype object"):
        synthetic.publish_synthetic(
            data_root, extra_arrays={"bad": np.array([{"a": 1}], dtype=object)}
        )
    with pytest.raises(BundleError, match="dtype <U"):
        synthetic.publish_synthetic(data_root, extra_arrays={"names": np.array(["a", "b"])})
    with pytest.raises(BundleError, match="not a plain file name"):
        synthetic.publish_synthetic(data_root, extra_arrays={"../x": np.zeros(2)})
    with pytest.raises(BundleError, match="name of a model array"):
        synthetic.publish_synthetic(data_root, extra_arrays={"response": np.zeros(2)})
    assert not (data_root / "sim").exists() or not list((data_root / "sim").iterdir())


def test_manifest_inputs_are_checked(data_root: Path, synthetic):
    with pytest.raises(BundleError, match=r"procedure\.gain is nan"):
        synthetic.publish_synthetic(data_root, procedure={"gain": float("nan")})
    with pytest.raises(BundleError, match=r"procedure\.fn has type object"):
        synthetic.publish_synthetic(data_root, procedure={"fn": object()})
    with pytest.raises(BundleError, match="has no valid 'sha256'"):
        synthetic.publish_synthetic(data_root, inputs=[{"id": "s1", "sha256": "xyz"}])
    with pytest.raises(BundleError, match="rig_name"):
        synthetic.publish_synthetic(data_root, rig={"no_name": True})
    with pytest.raises(BundleError, match="not a plain folder name"):
        synthetic.publish_synthetic(data_root, rig_name="../escape")
    with pytest.raises(BundleError, match="CalibrationModels"):
        publish({"not": "models"}, rig={"name": "sim"}, quality={"checks": []}, procedure={})


def test_numpy_values_become_json(data_root: Path, synthetic):
    path = synthetic.publish_synthetic(
        data_root,
        procedure={
            "exposure_ms": np.float32(12.5),
            "lasers": np.array([450, 520]),
            "n": np.int64(3),
        },
    )
    procedure = json.loads((path / "manifest.json").read_text())["procedure"]
    assert procedure == {"exposure_ms": 12.5, "lasers": [450, 520], "n": 3}


def test_reports_are_checksummed(data_root: Path, synthetic, tmp_path: Path):
    png = tmp_path / "plot.png"
    png.write_bytes(b"\x89PNG fake")
    path = synthetic.publish_synthetic(
        data_root, reports={"plot.png": png, "notes.md": "# notes\n", "raw.bin": b"\x00\x01"}
    )
    assert (path / "report" / "plot.png").read_bytes() == b"\x89PNG fake"
    manifest = json.loads((path / "manifest.json").read_text())
    assert set(manifest["reports"]) == {"plot.png", "notes.md", "raw.bin"}
    load(path)


def _slow_latest_writer(folder: str, version: str, marker: str) -> None:
    """Child process: update LATEST to ``version`` as a publisher that is slow between
    reading LATEST and replacing it (its file write waits until the parent has moved)."""
    from sassi_bench.bundle import layout

    real = layout.atomic_write_text

    def slow(path, text, **kwargs):
        Path(marker).touch()
        time.sleep(2.0)
        return real(path, text, **kwargs)

    layout.atomic_write_text = slow
    layout.update_latest(Path(folder), version)


def test_latest_never_goes_back_to_an_older_version_across_processes(tmp_path: Path):
    from sassi_bench.bundle.layout import update_latest

    folder = tmp_path / "sim"
    for version in ("v0001", "v0002", "v0003"):
        (folder / version).mkdir(parents=True)
    (folder / "LATEST").write_text("v0001\n")
    marker = tmp_path / "reading"
    methods = multiprocessing.get_all_start_methods()
    ctx = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
    older = ctx.Process(target=_slow_latest_writer, args=(str(folder), "v0002", str(marker)))
    older.start()
    try:
        deadline = time.monotonic() + 60
        while not marker.exists():  # the older publisher has read LATEST and is writing
            assert time.monotonic() < deadline and older.is_alive()
            time.sleep(0.02)
        update_latest(folder, "v0003")  # the newer one finishes meanwhile
    finally:
        older.join(timeout=60)
    assert older.exitcode == 0
    assert (folder / "LATEST").read_text() == "v0003\n"
