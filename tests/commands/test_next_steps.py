"""Each long command ends with the command a lab runs next, one the command line takes
with the bundle the command published or validated; a finished batch says where its
results are."""

from __future__ import annotations

import shlex
from pathlib import Path
from types import SimpleNamespace

import pytest

from sassi_bench.commands import batch as batch_cli
from sassi_bench.commands import build_parser
from sassi_bench.commands import calibrate as cli
from sassi_bench.commands import validate as validate_cli

RIG = SimpleNamespace(description=SimpleNamespace(name="sim"))
PUBLISHED = Path("lab data/bundles/sim/v0007")


def _next_commands(printed: str) -> list[list[str]]:
    """The commands under ``next:``, as argv words after the program."""
    lines = printed.split("next:\n", 1)[1].splitlines()
    return [shlex.split(line)[1:] for line in lines if line.startswith("  sassi-bench ")]


def _stand_ins(monkeypatch) -> None:
    """Each stage's workflow stands in for a run that published ``PUBLISHED``."""
    checks = []
    spectral = SimpleNamespace(
        checks=checks, sessions=[], bundle_path=PUBLISHED, passed=True,
        dispersion=SimpleNamespace(bins=SimpleNamespace(count=2, centres_nm=[400.0, 700.0])),
    )  # fmt: skip
    guide = SimpleNamespace(
        checks=checks, bundle_path=PUBLISHED, passed=True, homography=[[1.0, 0.0, 0.0]],
        registration=SimpleNamespace(quality=SimpleNamespace(dense_correlation=None)),
        reference=SimpleNamespace(rendering="design", stride=(4, 4)),
    )  # fmt: skip
    patches = {
        "sassi_bench.rig.open_rig": lambda *a, **k: RIG,
        "sassi_bench.workflows.spectral.run_spectral_calibration": lambda *a, **k: spectral,
        "sassi_bench.reduce.spectral.spectral_notes": lambda result: [],
        "sassi_bench.acquire.plan_geometry.scan_pitch": lambda *a: (4, 4),
        "sassi_bench.workflows.scan.check_scan": lambda *a: None,
        "sassi_bench.reduce.response.response_source": lambda *a: None,
        "sassi_bench.workflows.scan.run_response": lambda *a, **k: PUBLISHED,
        "sassi_bench.workflows.guide.run_guide_registration": lambda *a, **k: guide,
    }
    for target, stand_in in patches.items():
        monkeypatch.setattr(target, stand_in)
    parent = SimpleNamespace(version="v0006")
    monkeypatch.setattr(cli, "bundle_from_args", lambda *a, **k: parent)


@pytest.mark.parametrize(
    ("stage", "following"),
    [
        ("spectral", ["calibrate", "response"]),
        ("response", ["calibrate", "guide"]),
        ("guide", ["validate", "macbeth"]),
    ],
)
def test_a_calibration_stage_names_the_next_stage_on_its_new_bundle(
    stage, following, monkeypatch, capsys
):
    _stand_ins(monkeypatch)
    argv = ["calibrate", stage, "--rig", "sim", "--data", "lab data", "--quiet"]
    args = build_parser().parse_args(argv)
    assert args.func(args) == 0
    (command,) = _next_commands(capsys.readouterr().out)
    assert command[:2] == following
    parsed = build_parser().parse_args(command)
    assert (parsed.rig, parsed.bundle, parsed.data) == ("sim", "v0007", "lab data")
    if following[0] == "calibrate":  # a failed parent needs the same override again
        assert not parsed.allow_failed and not parsed.simulate
    else:
        assert parsed.out == "macbeth-report"


def test_a_stage_run_with_overrides_passes_them_on(monkeypatch, capsys):
    _stand_ins(monkeypatch)
    argv = ["calibrate", "spectral", "--rig", "hw.yaml", "--simulate", "--allow-failed"]
    args = build_parser().parse_args(argv)
    args.func(args)
    (command,) = _next_commands(capsys.readouterr().out)
    parsed = build_parser().parse_args(command)
    assert parsed.simulate and parsed.allow_failed and parsed.rig == "hw.yaml"
    assert parsed.data is None


def test_a_stage_that_published_nothing_names_no_next_stage(monkeypatch, capsys):
    _stand_ins(monkeypatch)
    args = build_parser().parse_args(["calibrate", "spectral", "--no-publish"])
    monkeypatch.setattr(
        "sassi_bench.workflows.spectral.run_spectral_calibration",
        lambda *a, **k: SimpleNamespace(
            checks=[], sessions=[], bundle_path=None, passed=True,
            dispersion=SimpleNamespace(bins=SimpleNamespace(count=2, centres_nm=[400.0, 700.0])),
        ),
    )  # fmt: skip
    args.func(args)
    assert "next:" not in capsys.readouterr().out


@pytest.mark.parametrize(
    ("kind", "named", "pinned"),
    [
        ("macbeth", None, "v0004"),  # latest, pinned to the version validated
        ("macbeth", "3", "v0004"),
        ("snapshot", "/lab/bundles/sim/v0004", "/lab/bundles/sim/v0004"),
    ],
)
def test_a_passed_validation_names_its_report_and_a_command_with_its_bundle(
    kind, named, pinned, tmp_path, capsys
):
    argv = ["validate", kind, "--out", "report", "--data", "lab data"]
    argv += ["--bundle", named] if named else []
    args = build_parser().parse_args(argv)
    bundle = SimpleNamespace(version="v0004")
    report = tmp_path / "a report" / f"{kind}_report.html"
    after = "check" if kind == "macbeth" else "snapshot take"
    validate_cli._print_next(args, bundle, report, True, after)
    printed = capsys.readouterr().out
    assert f"  open {report.resolve().as_uri()}\n" in printed
    (command,) = _next_commands(printed)
    assert command[: len(after.split())] == after.split()
    parsed = build_parser().parse_args(command)
    assert (parsed.rig, parsed.bundle, parsed.data) == ("sim", pinned, "lab data")
    if kind == "snapshot":
        assert (parsed.scene, parsed.out) == ("natural", "snapshots")


def test_a_failed_validation_names_its_report_only(tmp_path, capsys):
    args = build_parser().parse_args(["validate", "macbeth", "--out", "report"])
    report = tmp_path / "macbeth_report.html"
    validate_cli._print_next(args, SimpleNamespace(version="v0004"), report, False, "check")
    printed = capsys.readouterr().out
    assert printed.startswith("next:\n") and report.as_uri() in printed
    assert _next_commands(printed) == []


@pytest.mark.parametrize(("kind", "output"), [("assemble", ".nc"), ("validate", ".macbeth.json")])
def test_a_finished_batch_names_its_summary_and_where_its_outputs_are(
    kind, output, tmp_path, capsys
):
    summary = tmp_path / f"batch-{kind}.html"
    done = SimpleNamespace(kind=kind, summary_html=summary)
    batch_cli._print_next(done, tmp_path)
    lines = capsys.readouterr().out.splitlines()
    assert lines[:2] == ["next:", f"  open {summary.as_uri()}"]
    assert lines[-1].endswith(f"one <session>{output} per session, in {tmp_path}")
