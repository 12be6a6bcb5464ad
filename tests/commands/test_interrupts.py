"""Stopping a run from outside, with real processes and real signals: SIGTERM ends a run
like Ctrl-C (resume command printed and recorded, frames kept), SIGKILL leaves a record
that ``data list`` reads, and a second procedure on a rig that is being driven is refused
with the first one named."""

from __future__ import annotations

import ctypes
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from sassi_bench._shared.lock import WriteLock
from sassi_bench.acquire.session import Session
from sassi_bench.commands import PROG
from sassi_bench.commands.interrupts import Stopped, stop_signals

SCRIPT = Path(sys.executable).with_name("sassi-bench")


def _started_as(script: Path) -> str:
    """How the command line names itself in printed commands when started as ``script``
    (``commands.options.program``): the bare name only if PATH finds that very file."""
    found = shutil.which(PROG)
    return PROG if found and Path(found).resolve() == script.resolve() else str(script.absolute())


STARTED = _started_as(SCRIPT)


def _start(argv: list[str]) -> subprocess.Popen:
    return subprocess.Popen(
        [str(SCRIPT), *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


def _first_frame(process: subprocess.Popen, data: Path, timeout: float = 300) -> None:
    """Wait until the run has stored a frame."""
    deadline = time.monotonic() + timeout
    while not any(p.stat().st_size for p in data.glob("**/events.jsonl")):
        assert process.poll() is None, process.communicate()
        assert time.monotonic() < deadline, "no frame was stored in time"
        time.sleep(0.2)


def _stored(session: Path) -> int:
    return len(Session.open(session).completed)


def test_a_second_calibration_is_refused_and_sigterm_stops_the_first_like_ctrl_c(tmp_path):
    data = tmp_path / "data"
    argv = ["calibrate", "--rig", "sim", "--data", str(data), "--quiet"]
    first = _start(argv)
    try:
        _first_frame(first, data)
        second = subprocess.run([str(SCRIPT), *argv], capture_output=True, text=True, timeout=300)
        assert second.returncode == 2, second.stderr
        assert "rig 'sim' is driven by another procedure" in second.stderr
        assert f"pid {first.pid} on" in second.stderr and "calibrate" in second.stderr
        assert len(list((data / "staging").iterdir())) == 1, "the refused run captured nothing"
        first.send_signal(signal.SIGTERM)
        _, err = first.communicate(timeout=120)
    finally:
        first.kill()
    assert first.returncode == 128 + signal.SIGTERM, err
    assert "Traceback" not in err and "stopped by SIGTERM" in err
    tokens = shlex.split(err.strip().splitlines()[-1])
    assert tokens[: len(argv) + 1] == [STARTED, *argv] and tokens[-2] == "--session"
    (record,) = (data / "runs").glob("*.json")
    saved = json.loads(record.read_text())
    assert saved["status"] == "interrupted" and saved["note"] == "SIGTERM"
    assert shlex.split(saved["command"]) == tokens
    sessions = (data / "staging" / tokens[-1] / "sessions").iterdir()
    assert sum(_stored(s) for s in sessions) >= 1, "the frames stored before SIGTERM are kept"
    free = WriteLock(data / "locks" / "sim.lock")
    free.acquire()  # the stopped run let go of the rig
    free.release()


def test_sigkill_leaves_a_record_that_data_list_reads(tmp_path):
    data = tmp_path / "data"
    argv = ["calibrate", "spectral", "--rig", "sim", "--data", str(data), "--quiet"]
    process = _start(argv)
    try:
        _first_frame(process, data)
        process.send_signal(signal.SIGKILL)
        process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == -signal.SIGKILL
    sessions = sorted((data / "sessions").iterdir())
    assert sum(_stored(s) for s in sessions) >= 1
    listing = subprocess.run(
        [str(SCRIPT), "data", "list", "--data", str(data)], capture_output=True, text=True,
        timeout=120,
    )  # fmt: skip
    out = listing.stdout
    run = sessions[0].name.rsplit("-", 1)[0]  # spectral-<time>-grey: the run is spectral-<time>
    assert f"run {run}: interrupted (its process is gone)" in out
    resume = out.split("Resume with:\n", 1)[1].splitlines()[0].strip()
    assert shlex.split(resume) == [STARTED, *argv, "--session", run]
    assert "INCOMPLETE" in out


@pytest.mark.skipif(not hasattr(os, "fork"), reason="needs POSIX processes")
def test_a_procedure_on_a_rig_another_process_drives_is_refused(tmp_path):
    data = tmp_path / "data"
    holder = subprocess.Popen(
        [sys.executable, "-c", (
            "import sys, time\n"
            "from sassi_bench import open_rig\n"
            "from sassi_bench.workflows.rig_lock import driving\n"
            f"with driving(open_rig('sim'), {str(data)!r}, 'holder'):\n"
            "    print('held', flush=True)\n"
            "    time.sleep(300)\n"
        )],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert holder.stdout.readline().strip() == "held"
        refused = subprocess.run(
            [str(SCRIPT), "calibrate", "spectral", "--data", str(data), "--no-publish"],
            capture_output=True, text=True, timeout=300,
        )  # fmt: skip
    finally:
        holder.kill()
        holder.wait()
    assert refused.returncode == 2, refused.stderr
    assert f"rig 'sim' is driven by another procedure (pid {holder.pid} on" in refused.stderr
    assert refused.stderr.count("\n") == 1
    assert not (data / "sessions").exists()


def test_a_stop_signal_raised_inside_a_c_callback_still_stops_the_block(capsys):
    reached = []

    @ctypes.CFUNCTYPE(None)
    def callback():  # a C library calling back into Python, as a JIT compiler does
        signal.raise_signal(signal.SIGTERM)
        reached.append("callback ran on")

    with pytest.raises(Stopped) as stopped, stop_signals():
        callback()
        reached.append("block ran on")
    assert stopped.value.signum == signal.SIGTERM
    assert reached == []
    assert "Exception ignored" not in capsys.readouterr().err
