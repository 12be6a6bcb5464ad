"""``sassi-bench scan``'s closing line: the next command it names is one the CLI takes."""

from __future__ import annotations

import shlex
from pathlib import Path

import pytest

from sassi_bench.commands import build_parser
from sassi_bench.commands.scan import next_step


@pytest.mark.parametrize(
    "extra",
    [[], ["--data", "/lab data/root", "--bundle", "v0002", "--bundle-rig", "sim"]],
    ids=["defaults", "data and bundle given"],
)
def test_the_next_step_parses_as_a_snapshot_validation_of_this_cube(extra):
    parser = build_parser()
    scan = parser.parse_args(["scan", "--scene", "natural", "--out", "out/c 1.nc", *extra])
    line = next_step(scan, Path(scan.out))
    command = shlex.split(line[line.index("sassi-bench ") :])
    assert command[:3] == ["sassi-bench", "validate", "snapshot"]
    validate = parser.parse_args(command[1:])
    assert validate.scan == "out/c 1.nc"
    assert (validate.rig, validate.scene) == (scan.rig, scan.scene)
    assert (validate.data, validate.bundle) == (scan.data, scan.bundle)
