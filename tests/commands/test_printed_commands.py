"""Commands the workbench prints (what to run next, how to resume) work when pasted: they
name the program as it was started, a virtual environment's path when that is not on
PATH."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.acquire.plan import Plan, Step
from sassi_bench.acquire.session import Session
from sassi_bench.rig import Frame, FrameMeta, load_rig_description

SCRIPT = Path(sys.executable).with_name("sassi-bench")


@pytest.fixture(scope="module")
def root(tmp_path_factory) -> Path:
    """A data root with one session whose header is gone (data list prints a command)."""
    data = tmp_path_factory.mktemp("printed") / "data"
    plan = Plan("p", [Step("spectral", "off", 0.01, {"kind": "blank"})])
    session = Session.create(load_rig_description("sim"), plan, session_id="s1", data=data)
    session.write_frame(
        0, Frame(np.ones((2, 2), np.uint16), FrameMeta("spectral", 0.01, 0, 0, "off", 0))
    )
    (session.path / "session.json").unlink()
    return data


def _printed_verify(command: list[str], root: Path, path: str) -> str:
    env = {**os.environ, "PATH": path}
    done = subprocess.run(
        [*command, "data", "list", "--data", str(root)], capture_output=True, text=True,
        env=env, timeout=300, check=True,
    )  # fmt: skip
    line = next(s for s in done.stdout.splitlines() if "data verify" in s)
    return line.split("what is left of each: ", 1)[1]


def test_started_by_its_path_the_printed_commands_name_that_path(root):
    elsewhere = os.pathsep.join(
        p for p in os.environ.get("PATH", "").split(os.pathsep) if Path(p) != SCRIPT.parent
    )
    printed = _printed_verify([str(SCRIPT)], root, elsewhere)
    assert printed == f"{SCRIPT.absolute()} data verify sessions/s1 --data {root}"


def test_found_on_path_the_printed_commands_name_it_bare(root):
    path = os.pathsep.join([str(SCRIPT.parent), os.environ.get("PATH", "")])
    printed = _printed_verify([str(SCRIPT)], root, path)
    assert printed == f"sassi-bench data verify sessions/s1 --data {root}"


def test_started_as_a_module_the_printed_commands_do_the_same(root):
    printed = _printed_verify([sys.executable, "-m", "sassi_bench"], root, os.environ["PATH"])
    assert printed.startswith(f"{sys.executable} -m sassi_bench data verify sessions/s1")
