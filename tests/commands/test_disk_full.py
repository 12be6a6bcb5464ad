"""A disk that fills up during a capture: one line saying so, the frames kept, a resume
command; a capture that cannot fit is refused before it starts. Run on real small disks:
tmpfs folders of a few MB in a private mount namespace."""

from __future__ import annotations

import errno
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import sassi_bench.commands.rig
from sassi_bench._shared.disk import DISK_FULL_FIX
from sassi_bench.commands import PROG, main

SCRIPT = Path(sys.executable).with_name("sassi-bench")


def _can_mount_tmpfs(folder: Path) -> bool:
    if shutil.which("unshare") is None:
        return False
    probe = f"mount -t tmpfs -o size=1m tmpfs {shlex.quote(str(folder))}"
    return subprocess.run(["unshare", "-m", "sh", "-c", probe], capture_output=True).returncode == 0


ARGV = ["calibrate", "spectral", "--rig", "sim", "--quiet"]


def _calibrate_on_tmpfs(data: Path, size: str) -> tuple[list[str], str]:
    """``calibrate spectral`` into a tmpfs of ``size`` at ``data``; its stdout lines (the
    exit status, then per session its stored and verified frames, then the number of
    half-written chunks left) and its stderr."""
    data.mkdir()
    if not _can_mount_tmpfs(data):
        pytest.skip("needs a private mount namespace and tmpfs (root, util-linux unshare)")
    run = " ".join(shlex.quote(a) for a in [str(SCRIPT), *ARGV, "--data", str(data)])
    folder = shlex.quote(str(data))
    # The tmpfs lives in the namespace only; the session is read back before it goes.
    check = (
        f"{shlex.quote(sys.executable)} -c 'import sys; "
        "from sassi_bench.acquire.session import Session; "
        "s = Session.open(sys.argv[1]); print(len(s.completed), s.verify())' "
    )
    script = (
        f"mount -t tmpfs -o size={size} tmpfs {folder} && {{ {run}; echo rc=$?; "
        f'for s in {folder}/sessions/*; do {check} "$s"; done; '
        f"find {folder} -name '*.partial' | wc -l; }}"
    )
    done = subprocess.run(
        ["unshare", "-m", "sh", "-c", script], capture_output=True, text=True, timeout=300
    )
    return done.stdout.splitlines(), done.stderr


def _resume(err: str, data: Path) -> None:
    resume = shlex.split(err.split("Resume with:\n", 1)[1].strip())
    found = shutil.which(PROG)  # printed as started: see commands.options.program
    started = PROG if found and Path(found).resolve() == SCRIPT.resolve() else str(SCRIPT)
    assert resume[: len(ARGV) + 3] == [started, *ARGV, "--data", str(data)]
    assert resume[-2] == "--session"


def test_a_capture_that_fills_the_disk_says_so_in_one_line_and_keeps_its_frames(tmp_path):
    data = tmp_path / "data"
    # The grey plan's 18 frames fit at the least stored share (3.7 MB), not as stored.
    out, err = _calibrate_on_tmpfs(data, "5m")
    assert out[0] == "rc=2", err
    assert "Traceback" not in err
    first = err.splitlines()[0]
    assert first.startswith("error: session 'spectral-") and " write step " in first
    assert "is full (0 MB free); this frame was not stored. Fix: free space" in first
    (stored, verified) = map(int, out[1].split())
    assert stored >= 1 and verified == stored, "the frames stored before the disk filled"
    assert out[2] == "0", "no half-written chunk is left behind"
    _resume(err, data)


def test_a_capture_that_cannot_fit_is_refused_before_its_first_frame(tmp_path):
    data = tmp_path / "data"
    out, err = _calibrate_on_tmpfs(data, "1m")
    assert out[0] == "rc=2", err
    first = err.splitlines()[0]
    assert first.startswith("error: run plan 'spectral-grey': its 18 frames to capture take at ")
    assert f"MB, and the disk holding {data}/sessions/spectral-" in first
    assert first.endswith(f"MB free. Fix: {DISK_FULL_FIX}")
    assert out[1].split() == ["0", "0"], "nothing was captured"
    _resume(err, data)


def test_any_command_that_meets_a_full_disk_ends_in_one_line_naming_the_file(
    tmp_path, monkeypatch, capsys
):
    target = tmp_path / "report.html"

    def fills_the_disk(args):
        raise OSError(errno.ENOSPC, "No space left on device", str(target))

    monkeypatch.setattr(sassi_bench.commands.rig, "_show", fills_the_disk)
    assert main(["rig", "show", "--rig", "sim"]) == 2
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith(f"error: rig: the disk holding {target} is full (")
    assert line.endswith(f"Fix: {DISK_FULL_FIX}")


def test_other_write_failures_are_not_called_a_full_disk(monkeypatch):
    def refused(args):
        raise PermissionError(errno.EACCES, "Permission denied", "/x")

    monkeypatch.setattr(sassi_bench.commands.rig, "_show", refused)
    with pytest.raises(PermissionError):
        main(["rig", "show", "--rig", "sim"])
