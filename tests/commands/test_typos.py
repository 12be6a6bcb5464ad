"""A mistyped option is named as such, with the closest option of its command, before any
positional argument is judged (argparse alone blames the next argument)."""

from __future__ import annotations

import argparse

import pytest

from sassi_bench.commands import build_parser, main
from sassi_bench.commands.typos import unknown_option


@pytest.mark.parametrize(
    ("argv", "command", "typo", "meant"),
    [
        (["calibrate", "--rgi", "sim"], "calibrate", "--rgi", "--rig"),
        (["calibrate", "--rig", "sim", "--sesion", "foo"], "calibrate", "--sesion", "--session"),
        (["check", "--rig", "sim", "--bundel", "latest"], "check", "--bundel", "--bundle"),
        (["calibrate", "spectral", "--no-publsh"], "calibrate spectral", "--no-publsh",
         "--no-publish"),
        (["scan", "--roi", "1", "2", "3", "4", "--ot", "x.nc"], "scan", "--ot", "--out"),
        (["data", "clean", "--include-damagd"], "data clean", "--include-damagd",
         "--include-damaged"),
    ],
)  # fmt: skip
def test_a_typo_is_named_with_a_did_you_mean(argv, command, typo, meant, capsys):
    with pytest.raises(SystemExit) as stopped:
        main(argv)
    assert stopped.value.code == 2
    last = capsys.readouterr().err.strip().splitlines()[-1]
    assert last.startswith(f"sassi-bench {command}: error: unrecognized option {typo}; ")
    assert f"did you mean {meant}?" in last and "invalid choice" not in last


def test_what_argparse_accepts_is_left_to_it():
    parser = build_parser()
    accepted = [
        ["calibrate", "--ses", "x", "--rig", "sim"],  # a unique prefix
        ["calibrate", "--session=x", "spectral"],
        ["data", "clean", "--older-than", "-1"],  # a negative number is a value
        ["scan", "--pitch", "100", "5", "--out", "c.nc", "--roi", "0", "0", "10", "10"],
        ["batch", "validate", "--all", "--out", "o", "--corners", *["-1.5"] * 8],
        ["data", "verify", "--", "--odd-session-name"],
    ]
    for argv in accepted:
        assert unknown_option(parser, argv) is None, argv
    # an ambiguous prefix is argparse's to answer (it names the candidates)
    assert unknown_option(parser, ["scan", "--bundl", "x"]) is None


def test_an_option_of_another_command_gets_no_far_fetched_suggestion():
    parser = argparse.ArgumentParser(prog="demo")
    parser.add_argument("--rig")
    assert unknown_option(parser, ["--completely-different"]) == (
        parser,
        "--completely-different",
        None,
    )
