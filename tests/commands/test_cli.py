"""Every command of ``sassi-bench``: bad arguments end in one clean line, Ctrl-C in the
command that resumes the run.

The commands are enumerated from the parser, so a new command or option is covered
(or the test asks for a bad value for it).
"""

from __future__ import annotations

import argparse
import dataclasses
import importlib.util
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import sassi_bench.rig
from sassi_bench.commands import PROG, build_parser, main
from sassi_bench.rig.config import load_rig_description

_SPEC = importlib.util.spec_from_file_location(
    "sassi_bench_test_synthetic", Path(__file__).parents[1] / "bundle" / "conftest.py"
)
synthetic = importlib.util.module_from_spec(_SPEC)
sys.modules[_SPEC.name] = synthetic
_SPEC.loader.exec_module(synthetic)


def leaf_commands(parser: argparse.ArgumentParser, prefix=()):
    """(command words, parser) of every command that runs something."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if parser.get_default("func") is not None:
        yield prefix, parser
    for sub in subs:
        for name, child in sub.choices.items():
            yield from leaf_commands(child, (*prefix, name))


COMMANDS = list(leaf_commands(build_parser()))
IDS = [" ".join(words) for words, _ in COMMANDS]


def options(parser: argparse.ArgumentParser):
    """The arguments of a command that take a value."""
    for action in parser._actions:
        if isinstance(action, (argparse._HelpAction, argparse._SubParsersAction)):
            continue
        if action.nargs == 0:  # flags: no value to get wrong
            continue
        yield action


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A data root with one (synthetic) sim bundle, a plain file, and an exported zip."""
    from sassi_bench.bundle.archive import export_zip

    root = tmp_path_factory.mktemp("cli")
    data = root / "data"
    bundle = synthetic.publish_synthetic(data)
    afile = root / "afile.txt"
    afile.write_text("not a folder\n")
    zipped = export_zip(bundle, root / "bundle.zip")
    snapshot_session(data)
    snapshot_video(data)
    live_video(root / "live" / "video.zarr", bundle)
    return {"root": root, "data": data, "bundle": bundle, "file": afile, "zip": zipped}


def live_video(path: Path, bundle_path: Path) -> None:
    """A one-frame store of ``snapshot live`` (one region, uniform scale)."""
    import numpy as np

    from sassi_bench.bundle.loader import load
    from sassi_bench.snapshot.factored import Rank1Cube
    from sassi_bench.snapshot.video_store import VideoStore

    bundle = load(bundle_path)
    h, w = bundle.slm_shape
    cube = Rank1Cube(
        np.zeros((h, w), np.intp),
        np.ones((h, w), np.float32),
        np.ones((1, bundle.wavelengths.size), np.float32),
    )
    store = VideoStore(path, bundle, units="relative")
    store.append(cube, np.zeros((h, w), bool), time_s=0.0, frame_index=0)


def snapshot_session(data: Path) -> None:
    """A session ``snap`` on the sim rig: a pinhole spectral frame (step 0) and a guide
    frame (step 1), for the commands that read captured frames."""
    from sassi_bench.acquire.plan import Plan, Step
    from sassi_bench.acquire.runner import run_plan
    from sassi_bench.acquire.session import Session

    rig = sassi_bench.rig.open_rig("sim")
    pinholes = {"kind": "pinholes", "pitch": [100, 5], "offset": [0, 0]}
    plan = Plan(
        "snap",
        (
            Step("spectral", "led", 0.01, pinholes, {"role": "snapshot"}),
            Step("guide", "led", 0.005, {"kind": "blank"}, {"role": "guide"}),
        ),
        {"scene": "white"},
    )
    run_plan(rig, plan, Session.create(rig.description, plan, session_id="snap", data=data))


def snapshot_video(data: Path) -> None:
    """A one-frame snapshot ``snapvid`` on the sim rig (a fixed pinhole mask), for
    ``snapshot reconstruct``."""
    import numpy as np

    from sassi_bench.acquire.snapshots import capture_snapshots

    rig = sassi_bench.rig.open_rig("sim")
    mask = np.zeros(rig.slm.shape, bool)
    mask[10::25, 20::100] = True
    capture_snapshots(
        rig, lambda guide: mask, prefix="snapvid", scene="natural", mask_kind="uniform",
        exposure_pattern={"kind": "pinholes", "pitch": [100, 25]}, data=data, progress=False,
    )  # fmt: skip


@pytest.fixture(autouse=True)
def shared_rigs(monkeypatch):
    """Each rig is built once (descriptions are still loaded and checked every time)."""
    opened: dict[str, object] = {}
    real = sassi_bench.rig.open_rig

    def open_rig(rig="sim", *, simulate=False):
        desc = rig if not isinstance(rig, (str, Path)) else load_rig_description(rig)
        if desc.sha256() not in opened:
            opened[desc.sha256()] = real(desc)
        return opened[desc.sha256()]

    monkeypatch.setattr(sassi_bench.rig, "open_rig", open_rig)
    return opened


def valid_value(words, action, world):
    """A value a required argument can take."""
    dest, root = action.dest, world["root"]
    if dest == "out":
        return str(root / ("cube.nc" if words == ("scan",) else "out"))
    if dest == "session":
        return "snapvid" if words == ("snapshot", "reconstruct") else "snap"
    if dest == "sessions":
        return "snap"  # not a pinhole scan: refused before a cluster starts
    if dest == "step":
        return "0"
    if dest == "frames":
        return "1"
    if dest == "video":
        return str(root / "live")
    if dest == "path":
        return str(world["bundle"])
    if dest in ("a", "b"):
        return "v0001"
    if dest == "zip":
        if words[-1] == "import":
            return str(world["zip"])
        return str(root / f"export-{len(list(root.glob('export-*.zip')))}.zip")
    raise AssertionError(f"{' '.join(words)}: give a valid value for required {dest!r}")


def bad_value(words, action, world):
    """A value the command must refuse, or None where every value is acceptable."""
    root, afile = world["root"], str(world["file"])
    missing = str(root / "no-such-folder" / "x")
    by_dest = {
        "rig": "no-such-rig",
        "data": afile,
        "procedure": str(root / "missing-procedure.yaml"),
        "session": "../escape",
        "white_session": "../escape",
        "bundle": "v9999",
        "bundle_rig": "no-such-rig",
        "scene": "colorchekcer",
        "light": "lazer:532",
        "lights": "lazer:532",
        "pitch": ["0", "5"],
        "roi": ["50", "50", "10", "10"],
        "temperature": "-5",
        "reference": str(root / "missing.csv"),
        "corners": ["10"] * 8,
        "white": "grey",
        "grid": "many",
        "envi": missing,
        "version": "no-such-bundle",
        "a": "no-such-bundle",
        "b": "no-such-bundle",
        "path": str(root / "no-such-bundle"),
        "zip": missing + ".zip",
        "out": missing if words == ("scan",) else afile,
        "format": "bogus",
        "wavelengths": "blue",
        "vsize": "4",
        "position_quantum": "0.3",
        "step": "99",
        "tag": "novalue",
        "guide_step": "99",
        "guide_tag": "novalue",
        "guide_dark_tag": "novalue",
        "guide_session": "no-such-session",
        "limits": ["5", "1", "0", "10"],
        "port": "70000",
        "max_fps": "0",
        "exposure": "-1",
        "scan": str(root / "missing.nc"),
        "video": "-1",
        "mask": str(root / "missing.npy"),
        "older_than": "-3",
        "sessions": "no-such-scan-*",
        "scheduler": "not-an-address",
        "dashboard": "8787",
        "workers": "0",
        "frames": "0",
        "frame": "99",
        "seconds": "-1",
        "queue": "0",
        "since": "yesterday",
        "figure": str(root / "no-such-folder" / "layout.png"),
    }
    if words == ("snapshot", "export") and action.dest == "session":
        return "no-such-session"
    if words == ("bundle", "list") and action.dest == "rig":
        return None  # listing a rig with no bundles is not an error: it lists nothing
    if words in (("bundle", "verify"), ("bundle", "export")) and action.dest in ("data", "rig"):
        return None  # the bundle is given by its folder: --data and --rig are not read
    if words == ("validate", "macbeth") and action.dest == "reference":
        return "no-such-reference-data"
    if action.dest not in by_dest:
        raise AssertionError(
            f"'{' '.join(words)}' has an option {action.dest!r} without a bad value here: "
            "add one to bad_value()"
        )
    return by_dest[action.dest]


def argv_for(words, parser, world, bad=None):
    """Command line with every required argument valid and ``bad`` = (action, value)."""
    positional, optional = [], []
    for action in options(parser):
        if bad is not None and action is bad[0]:
            value = bad[1]
        elif action.required or (not action.option_strings and action.nargs != "?"):
            value = valid_value(words, action, world)
        else:
            continue
        values = value if isinstance(value, list) else [value]
        if action.option_strings:
            optional += [action.option_strings[0], *values]
        else:
            positional += values
    for group in parser._mutually_exclusive_groups:
        if group.required and not (bad is not None and bad[0] in group._group_actions):
            first = group._group_actions[0]
            optional += [first.option_strings[0], valid_value(words, first, world)]
    if "--data" not in optional and any(a.dest == "data" for a in options(parser)):
        optional += ["--data", str(world["data"])]
    return [*words, *positional, *optional]


def run(argv, capsys):
    """main(argv) in process: (exit status, stdout, stderr)."""
    try:
        status = main(argv)
    except SystemExit as exc:  # argparse
        status = exc.code
    out, err = capsys.readouterr()
    return status, out, err


#: What a command-line user cannot act on: Python calls and module paths.
API_HINT = re.compile(
    r"\b(Session|CalibrationBundle)\.[a-z_]+|sassi_bench\.[a-z_]+\.[A-Za-z_]|=True\b"
)


def bad_cases():
    for words, parser in COMMANDS:
        for action in options(parser):
            yield pytest.param(words, action.dest, id=f"{' '.join(words)} --{action.dest}")


@pytest.mark.parametrize(("words", "dest"), list(bad_cases()))
def test_a_bad_argument_gives_one_clean_line(words, dest, world, capsys):
    parser = dict(COMMANDS)[words]
    action = next(a for a in options(parser) if a.dest == dest)
    value = bad_value(words, action, world)
    if value is None:
        pytest.skip(f"every value of {dest} is acceptable")
    argv = argv_for(words, parser, world, bad=(action, value))
    status, _, err = run(argv, capsys)
    assert "Traceback" not in err
    assert status == 2, (argv, err)
    assert not API_HINT.search(err), f"a Python API hint for a command-line user: {err}"
    lines = err.strip().splitlines()
    if err.startswith("usage:"):  # argparse refused it: usage, then one error line
        assert lines[-1].startswith(f"{PROG} ") and ": error: " in lines[-1]
    else:
        assert len(lines) == 1, err
        assert lines[0].startswith("error: ") and ". Fix: " in lines[0], err
    shown = value[0] if isinstance(value, list) else value
    named = (shown, Path(shown).name, str(Path(shown).parent), f"({shown}", dest)
    assert any(text in err for text in named), (argv, err)


def test_scene_and_light_typos_are_refused_before_any_session(world, capsys):
    data = world["root"] / "typos"
    for option, value, hint in (
        ("--scene", "colorchekcer", "did you mean 'colorchecker'?"),
        ("--light", "lazer:532", "did you mean 'laser:532'?"),
    ):
        argv = ["scan", option, value, "--out", str(world["root"] / "c.nc"), "--data", str(data)]
        status, _, err = run(argv, capsys)
        assert status == 2 and hint in err and err.count("\n") == 1
    argv = ["validate", "snapshot", "--scene", "natral", "--out", str(world["root"] / "vs")]
    status, _, err = run([*argv, "--data", str(data)], capsys)
    assert status == 2 and "did you mean 'natural'?" in err and err.count("\n") == 1
    assert not (data / "sessions").exists()


def test_a_laser_the_rig_does_not_have_is_named_with_the_rig_s_lasers(world, capsys):
    argv = ["rig", "snapshot", "--light", "laser:405", "--out", str(world["root"] / "s")]
    status, _, err = run(argv, capsys)
    assert status == 2 and "'laser:405' is not a light of this rig" in err
    assert "laser:450, laser:520, laser:532, laser:635, laser:670" in err


def test_the_console_script_prints_one_line(world):
    script = Path(sys.executable).with_name("sassi-bench")
    result = subprocess.run(
        [str(script), "scan", "--scene", "colorchekcer", "--out", str(world["root"] / "c.nc")],
        capture_output=True,
        text=True,
        timeout=300,
        env={"SASSI_BENCH_DATA": str(world["data"]), "PATH": ""},
    )
    assert result.returncode == 2
    assert result.stderr.startswith("error: scan: unknown scene 'colorchekcer'")
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.stderr


# -- Ctrl-C -------------------------------------------------------------------------------

#: Commands that capture but keep nothing a later run could resume.
NOTHING_TO_RESUME = {("rig", "snapshot"), ("rig", "check"), ("align",), ("live",), ("check",)}
#: Commands whose interrupted run is complete as it stands: they say where it is.
KEEPS_WHAT_IT_TOOK = {("snapshot", "live")}


class _CtrlC:
    """A camera that is interrupted by Ctrl-C on its first capture."""

    def __init__(self, camera, log):
        self._camera, self._log = camera, log

    def __getattr__(self, name):
        return getattr(self._camera, name)

    def capture(self):
        self._log.append(self._camera.name)
        raise KeyboardInterrupt


@pytest.mark.parametrize("words", [w for w, _ in COMMANDS], ids=IDS)
def test_ctrl_c_prints_the_command_that_resumes(words, world, capsys, monkeypatch, shared_rigs):
    captured: list[str] = []
    real = sassi_bench.rig.open_rig

    def interrupted_rig(rig="sim", *, simulate=False):
        opened = real(rig, simulate=simulate)
        return dataclasses.replace(
            opened,
            spectral_camera=_CtrlC(opened.spectral_camera, captured),
            guide_camera=_CtrlC(opened.guide_camera, captured),
        )

    monkeypatch.setattr(sassi_bench.rig, "open_rig", interrupted_rig)
    parser = dict(COMMANDS)[words]
    argv = argv_for(words, parser, world)
    if words == ("bundle", "export"):
        argv += ["--zip", str(world["root"] / "ctrl-c.zip")]
    status, _, err = run(argv, capsys)
    if not captured:
        assert status != 130, "a command that captures nothing was interrupted"
        return
    assert status == 130 and "Traceback" not in err, err
    args = build_parser().parse_args(argv)
    if words in NOTHING_TO_RESUME:
        assert err.strip() == "interrupted"
        return
    if words in KEEPS_WHAT_IT_TOOK:
        assert err.strip().startswith("interrupted: ") and "video.zarr" in err, err
        return
    assert args.resume_options, f"{' '.join(words)} captures: give it resume_options"
    resume = err.strip().splitlines()[-1].strip()
    tokens = shlex.split(resume)
    assert tokens[0] == PROG and tokens[1 : len(argv) + 1] == argv
    resumed = build_parser().parse_args(tokens[1:])
    assert resumed.session and resumed.session.startswith(
        ("full-", "spectral-", "response-", "scan-", "guide-", "snapshot-")
    )
    assert {k: v for k, v in vars(resumed).items() if "session" not in k} == {
        k: v for k, v in vars(args).items() if "session" not in k
    }


def test_ctrl_c_in_a_real_calibration_prints_the_resume_command(tmp_path):
    """SIGINT to the console script in the middle of a capture, with --quiet."""
    import signal
    import time

    script = Path(sys.executable).with_name("sassi-bench")
    data = tmp_path / "data"
    argv = ["calibrate", "--rig", "sim", "--data", str(data), "--quiet"]
    process = subprocess.Popen(
        [str(script), *argv],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        # A background job inherits an ignored Ctrl-C; the user's terminal does not.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        deadline = time.monotonic() + 240
        while not any(p.stat().st_size for p in data.glob("**/events.jsonl")):
            assert process.poll() is None, process.communicate()
            assert time.monotonic() < deadline, "no frame was stored in time"
            time.sleep(0.2)
        process.send_signal(signal.SIGINT)
        _, err = process.communicate(timeout=120)
    finally:
        process.kill()
    assert process.returncode == 130, err
    assert "Traceback" not in err
    tokens = shlex.split(err.strip().splitlines()[-1])
    found = shutil.which(PROG)  # printed as started: see commands.options.program
    started = PROG if found and Path(found).resolve() == script.resolve() else str(script)
    assert tokens[: len(argv) + 1] == [started, *argv] and tokens[-2] == "--session"
    staged = data / "staging" / tokens[-1] / "sessions"
    frames = [p for p in staged.glob("*/events.jsonl") if p.stat().st_size]
    assert frames, "the resume command names the session the frames went to"
