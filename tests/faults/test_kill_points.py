"""Commands that write, stopped by a real SIGINT, SIGTERM or SIGKILL at fixed points: every
earlier result stays intact and readable, no half-written file is left under a final
name, and the run says how to resume (see ``fault_kit``). The randomized, longer version
over every command is ``benchmarks/fault_campaign.py``."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

import fault_kit as kit

#: (command, signal, trigger, run the resume to its end afterwards). A file trigger is a
#: glob under the lab's folder (data/, out/, other/): a temporary file being written.
#: Resuming a capture to its end is left to the campaign (minutes per run).
POINTS = [
    ("scan", "SIGINT", "frames:3", False),
    ("scan", "SIGKILL", "frames:4", False),
    ("snapshot take", "SIGTERM", "frames:1", False),
    ("rig snapshot", "SIGKILL", "file:out/snap/.*.tmp", True),
    ("bundle export zip", "SIGKILL", "file:out/.b.zip.*.tmp", True),
    ("bundle export sassi-mat", "SIGTERM", "file:out/mat/.*.tmp", True),
    ("bundle import", "SIGKILL", "file:other/sim/.import-*", True),
    ("snapshot reconstruct", "SIGINT", "file:out/rec/.*.tmp", True),
    ("data clean", "SIGKILL", "seconds:1.5", True),
]

#: Commands too quick for a trigger to land reliably (a file trigger lands: the kit holds
#: each file under its temporary name a while, see ``fault_kit.COMMIT_PAUSE_S``): the point
#: is checked either way.
RACY = {"data clean"}


@pytest.fixture(scope="module")
def lab(guided_bundle, tmp_path_factory) -> Path:
    """A lab's data root with earlier results, copied per kill point."""
    _, bundle, _, _ = guided_bundle
    template = tmp_path_factory.mktemp("fault-lab")
    kit.build_world(template, bundle.path)
    return template


@pytest.mark.parametrize(("name", "signame", "trigger", "finish"), POINTS)
def test_an_interrupted_command_loses_nothing_and_says_how_to_resume(
    lab, tmp_path, name, signame, trigger, finish
):
    case = kit.CASES[name]
    places = kit.fresh_lab(lab, tmp_path / "lab")
    roots = [places["data"], places["out"], places["other"], places["zip"].parent]
    argv = kit.fill(case.argv, places)
    before = kit.take_snapshot(roots)
    removable = kit.removable_by(case, places["data"])
    # triggers watch the lab's folder: a file trigger's glob starts at data/, out/, other/
    outcome = kit.kill_point(case, argv, places["data"], [tmp_path / "lab"], signame, trigger)
    kit.check_kill_point(case, outcome, before, roots, places["data"], removable)
    assert not outcome.problems, outcome.problems
    if name not in RACY:
        assert outcome.killed, "the command ended before the signal: no kill point was tried"
    if finish and outcome.killed:  # a racy command that finished has nothing to resume
        if name in kit.FRESH_OUT:
            places = dict(places, out=places["out"] / "again")
            places["out"].mkdir()
            argv = kit.fill(case.argv, places)
        problems = kit.resume(case, outcome, argv, places["data"])
        problems += kit.check_intact(before, kit.take_snapshot(roots), removable)
        problems += kit.check_whole(roots)
        assert not problems, problems
