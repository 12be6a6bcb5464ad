"""``sassi-bench align`` (also ``live``) as a lab runs it: the address printed, the rig
locked while it serves, SIGTERM stopping it cleanly with the rig's lock released; the
options of the view and of ``--no-view`` refused in the other form."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from sassi_bench.commands import build_parser, main
from sassi_bench.rig import load_rig_description
from sassi_bench.workflows.rig_lock import RigBusyError, driving

SCRIPT = Path(sys.executable).with_name("sassi-bench")


def status(url: str) -> dict:
    base, token = url.split("/?token=")
    with urllib.request.urlopen(f"{base}/status.json?token={token}", timeout=10) as answer:
        return json.load(answer)


def test_sigterm_stops_the_live_view_and_frees_the_rig(tmp_path):
    env = {**os.environ, "SASSI_BENCH_DATA": str(tmp_path)}
    argv = [str(SCRIPT), "align", "--rig", "sim", "--lights", "laser:532", "--max-fps", "5"]
    argv += ["--exposure", "0.05"]  # live frames at once; the readings' exposure comes later
    process = subprocess.Popen(
        argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env
    )
    try:
        first = process.stdout.readline()
        url = re.search(r"http://127\.0\.0\.1:\d+/\?token=\S+", first).group(0)
        assert "Ctrl-C stops it" in process.stdout.readline()
        desc = load_rig_description("sim")
        with pytest.raises(RigBusyError), driving(desc, tmp_path, "a second procedure"):
            pass  # refused: the live view holds the rig
        deadline = time.monotonic() + 300  # the first frame waits for kernels to compile
        while status(url)["cameras"]["spectral"]["capture_fps"] <= 0:
            assert time.monotonic() < deadline, status(url)
            time.sleep(0.5)
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=120)
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()
    assert process.returncode == 128 + signal.SIGTERM, err
    assert "stopped by SIGTERM" in err and "Traceback" not in err
    with driving(desc, tmp_path, "after the live view"):
        pass  # the lock was released
    assert not any(tmp_path.rglob("*.zarr"))  # the live view stores no frames


def test_live_is_another_name_for_align():
    parser = build_parser()
    live = vars(parser.parse_args(["live", "--rig", "sim", "--port", "8123"]))
    align = vars(parser.parse_args(["align", "--rig", "sim", "--port", "8123"]))
    assert (live.pop("command"), align.pop("command")) == ("live", "align")
    assert live == align and live["func"].__name__ == "_align" and not live["no_view"]


@pytest.mark.parametrize(
    ("argv", "said"),
    [
        (["align", "--no-view", "--max-fps", "5"], "align --no-view: --max-fps set the live view"),
        (["live", "--no-view", "--port", "8123"], "align --no-view: --port set the live view"),
        (["align", "--frames", "3"], "align: --frames counts the rounds --no-view prints"),
    ],
)
def test_options_of_the_other_form_are_refused_before_the_rig_opens(
    argv, said, tmp_path, capsys, monkeypatch
):
    import sassi_bench.rig

    def no_rig(*args, **kwargs):
        raise AssertionError("the rig was opened")

    monkeypatch.setattr(sassi_bench.rig, "open_rig", no_rig)
    assert main([*argv, "--data", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"error: {said}") and "Fix: " in err and err.count("\n") == 1
