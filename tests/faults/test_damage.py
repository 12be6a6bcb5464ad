"""A failing disk and a careless lab, tried from the command line on a lab's data root:
a frame chunk deleted, truncated or with a flipped byte, a truncated ``session.json``, and
two data roots on one hardware rig. Every command that reads the damage names it (session,
step, file, what is wrong) and either captures the frame again (a capture resuming its own
session) or stops before writing anything; damaged sessions are listed and never cleaned
unless asked; a rig that drives hardware is driven by one procedure, whatever the data
root. The randomized version over every file of a finished run is
``benchmarks/fault_campaign.py --damage``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

sys.path.insert(0, str(Path(__file__).parent))

import fault_kit as kit

#: A pinhole step of the lab's thin ColorChecker scan (``fault_kit.build_world``).
STEP = 1


@pytest.fixture(scope="module")
def lab(guided_bundle, tmp_path_factory) -> Path:
    """A lab's data root with earlier results, copied per test."""
    _, bundle, _, _ = guided_bundle
    template = tmp_path_factory.mktemp("damage-lab")
    kit.build_world(template, bundle.path)
    return template


@pytest.fixture()
def places(lab, tmp_path) -> dict[str, Path]:
    return kit.fresh_lab(lab, tmp_path / "lab")


def sassi(places, *argv: str) -> subprocess.CompletedProcess:
    done = kit.run_command([str(a) for a in argv], places["data"], timeout=900)
    assert "Traceback" not in done.stderr, done.stderr
    return done


def scan_chunk(data: Path, step: int = STEP) -> Path:
    log = (data / "sessions" / "world-scan" / "events.jsonl").read_text().splitlines()
    event = next(e for e in map(json.loads, log) if e["step"] == step)
    return (
        data
        / "sessions"
        / "world-scan"
        / "frames.zarr"
        / event["camera"]
        / "c"
        / str(event["slot"])
        / "0"
        / "0"
    )


def listed_state(places) -> str:
    out = sassi(places, "data", "list").stdout
    return next(line for line in out.splitlines() if "sessions/world-scan " in line)


def test_a_deleted_chunk_is_named_kept_and_captured_again(places):
    data, out = places["data"], places["out"]
    scan_chunk(data).unlink()
    assert "DAMAGED" in listed_state(places)
    listing = sassi(places, "data", "list").stdout
    assert f"sessions/world-scan: 1 frame missing (step {STEP})" in listing
    cleaned = sassi(places, "data", "clean", "--yes")
    assert "damaged sessions" in cleaned.stdout and (data / "sessions" / "world-scan").is_dir()
    # a batch reads it and stops: the session, the step, the file, what is wrong; no cube
    batch = sassi(places, "batch", "assemble", "--sessions", "world-scan", "--out",
                  out / "cubes", "--workers", "1", "--quiet")  # fmt: skip
    assert batch.returncode == 1
    assert (f"FAILED world-scan: FrameDamagedError: session 'world-scan' read step {STEP}: the "
            "spectral frame") in batch.stdout  # fmt: skip
    assert "is missing: its chunk file is gone" in batch.stdout
    assert not list((out / "cubes").glob("*.nc"))
    # the capture that made it, resumed, takes the frame again and finishes
    scan = sassi(places, "scan", "--rig", "sim", "--session", "world-scan", "--out",
                 out / "cube.nc", "--quiet")  # fmt: skip
    assert scan.returncode == 0, scan.stderr
    assert f"session 'world-scan' step {STEP}: missing: " in scan.stderr
    assert "captured again" in scan.stderr and (out / "cube.nc").is_file()
    verified = sassi(places, "data", "verify", "world-scan", "--quiet")
    assert verified.returncode == 0 and "every frame is as it was stored" in verified.stdout


def test_a_truncated_chunk_stops_a_command_before_it_writes(places):
    data, out = places["data"], places["out"]
    chunk = scan_chunk(data)
    stored = chunk.stat().st_size
    chunk.write_bytes(chunk.read_bytes()[:100])
    assert "DAMAGED" in listed_state(places)
    batch = sassi(places, "batch", "assemble", "--sessions", "world-scan", "--out",
                  out / "cubes", "--workers", "1", "--quiet")  # fmt: skip
    assert batch.returncode == 1 and not list((out / "cubes").glob("*.nc"))
    assert (f"is truncated: its chunk file is 100 bytes, {stored} were stored; it does not "
            "decode") in batch.stdout  # fmt: skip
    verify = sassi(places, "data", "verify", "world-scan", "--retake", "--quiet")
    assert verify.returncode == 1 and "set aside 1 frame(s)" in verify.stdout
    kept = list((data / "sessions" / "world-scan" / "damaged" / "spectral").iterdir())
    assert [p.stat().st_size for p in kept] == [100], "the damaged file is kept as found"
    assert "INCOMPLETE" in listed_state(places)  # the capture takes it again
    scan = sassi(places, "scan", "--rig", "sim", "--session", "world-scan", "--out",
                 out / "cube.nc", "--quiet")  # fmt: skip
    assert scan.returncode == 0 and "captured again" not in scan.stderr, scan.stderr
    assert sassi(places, "data", "verify", "world-scan", "--quiet").returncode == 0


def test_a_flipped_byte_is_found_on_read_and_by_verify(places):
    data, out = places["data"], places["out"]
    chunk = scan_chunk(data)
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0x04
    chunk.write_bytes(bytes(raw))
    assert "DAMAGED" not in listed_state(places)  # its size is right: only a read sees it
    verify = sassi(places, "data", "verify", "--quiet")
    assert verify.returncode == 1
    assert f"step {STEP}: the spectral frame (slot " in verify.stdout
    assert "1 of 4 session(s) damaged" in verify.stdout
    assert "found by the check of" in listed_state(places) or "DAMAGED" in listed_state(places)
    batch = sassi(places, "batch", "assemble", "--sessions", "world-scan", "--out",
                  out / "cubes", "--workers", "1", "--quiet")  # fmt: skip
    assert batch.returncode == 1 and not list((out / "cubes").glob("*.nc"))
    assert f"read step {STEP}: the spectral frame" in batch.stdout


def test_a_truncated_session_json_is_named_kept_and_never_planned_over(places):
    data, out = places["data"], places["out"]
    header = data / "sessions" / "world-scan" / "session.json"
    header.write_bytes(header.read_bytes()[:300])
    listing = sassi(places, "data", "list").stdout
    assert "sessions/world-scan: session.json is not JSON" in listing
    for clean in (("data", "clean", "--yes"), ("data", "clean", "--include-measurements",
                                                "--include-interrupted", "--yes")):  # fmt: skip
        sassi(places, *clean)
        assert header.is_file()
    scan = sassi(places, "scan", "--rig", "sim", "--session", "world-scan", "--out",
                 out / "cube.nc", "--quiet")  # fmt: skip
    assert scan.returncode == 2 and not (out / "cube.nc").exists()
    message = scan.stderr.strip().splitlines()[-1]
    assert message.startswith("error: session 'world-scan' open: session.json is not JSON")
    assert "readable frame events in events.jsonl" in message
    assert "the captured steps of the plan can be rebuilt from the log" in message
    assert "already exists" not in message
    verify = sassi(places, "data", "verify", "world-scan", "--quiet")
    assert verify.returncode == 1 and "what is left:" in verify.stdout
    logged = len((data / "sessions" / "world-scan" / "events.jsonl").read_text().splitlines())
    assert f"its {logged} logged frames checked against the log" in verify.stdout
    sassi(places, "data", "clean", "--include-damaged", "--include-measurements", "--yes")
    assert not (data / "sessions" / "world-scan").exists(), "removed when asked"


def _hold(rig: str, data: Path, env: dict[str, str]) -> subprocess.Popen:
    holder = subprocess.Popen(
        [sys.executable, "-c", (
            "import sys, time\n"
            "from sassi_bench.rig import load_rig_description\n"
            "from sassi_bench.workflows.rig_lock import driving\n"
            f"with driving(load_rig_description({rig!r}), {str(data)!r}, 'holder'):\n"
            "    print('held', flush=True)\n"
            "    time.sleep(300)\n"
        )],
        stdout=subprocess.PIPE, text=True, env=env,
    )  # fmt: skip
    assert holder.stdout.readline().strip() == "held"
    return holder


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX processes and flock")
def test_two_data_roots_on_one_hardware_rig_are_refused_before_start_up(tmp_path):
    env = {**os.environ, "SASSI_BENCH_LOCK_DIR": str(tmp_path / "machine-locks")}
    lab = tmp_path / "lab-example.yaml"
    description = yaml.safe_load(
        (Path(__file__).parents[2] / "procedures" / "rigs" / "lab-example.yaml").read_text()
    )
    lab.write_text(yaml.safe_dump(description))
    other = tmp_path / "lab-b.yaml"  # another description of the same bench
    other.write_text(yaml.safe_dump({**description, "name": "lab-b"}))
    holder = _hold(str(lab), tmp_path / "root-a", env)
    try:
        runs = {
            name: subprocess.run(
                [str(kit.SCRIPT), *argv], capture_output=True, text=True, env=env, timeout=300
            )
            for name, argv in {
                "same rig": ("calibrate", "spectral", "--rig", lab, "--data", tmp_path / "b"),
                "same devices": ("scan", "--rig", other, "--data", tmp_path / "c", "--out",
                                 tmp_path / "cube.nc"),
            }.items()
        }  # fmt: skip
    finally:
        holder.kill()
        holder.wait()
    same = runs["same rig"]
    assert same.returncode == 2 and same.stderr.count("\n") == 1, same.stderr
    assert f"rig 'lab-example' is driven by another procedure (pid {holder.pid} on" in same.stderr
    shared = runs["same devices"]
    assert shared.returncode == 2 and shared.stderr.count("\n") == 1, shared.stderr
    assert "the trigger of rig 'lab-b' (serial " in shared.stderr
    assert f"is driven by another procedure (pid {holder.pid} on" in shared.stderr
    # refused before the rig was opened (its serial port does not exist here) or anything
    # was written
    assert not (tmp_path / "b").exists() and not (tmp_path / "c").exists()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX processes and flock")
def test_the_virtual_bench_keeps_one_lock_per_data_root(tmp_path):
    env = {**os.environ, "SASSI_BENCH_LOCK_DIR": str(tmp_path / "machine-locks")}
    holder = _hold("sim", tmp_path / "root-a", env)
    try:
        other_root = _hold("sim", tmp_path / "root-b", env)  # no device: allowed
        other_root.kill()
        other_root.wait()
        refused = subprocess.run(
            [str(kit.SCRIPT), "calibrate", "spectral", "--data", str(tmp_path / "root-a")],
            capture_output=True, text=True, env=env, timeout=300,
        )  # fmt: skip
    finally:
        holder.kill()
        holder.wait()
    assert refused.returncode == 2 and "rig 'sim' is driven by another procedure" in refused.stderr
