"""`sassi-bench calibrate`: the whole chain without a procedure name, one stage with one."""

from sassi_bench.commands import build_parser
from sassi_bench.commands import calibrate as cli
from sassi_bench.commands.options import print_checks


def test_calibrate_without_a_procedure_runs_the_whole_chain():
    args = build_parser().parse_args(["calibrate", "--rig", "sim", "--quiet"])
    assert args.func is cli._full
    assert (args.rig, args.quiet, args.procedure) == ("sim", True, None)


def test_calibrate_with_a_procedure_runs_that_stage():
    parser = build_parser()
    assert parser.parse_args(["calibrate", "spectral"]).func is cli._spectral
    guide = parser.parse_args(["calibrate", "guide", "--full", "--rig", "sim-prototype"])
    assert guide.func is cli._guide and guide.full and guide.rig == "sim-prototype"


def test_checks_print_one_line_each(capsys):
    from sassi_bench.bundle import QualityCheck

    print_checks([QualityCheck.at_most("rms", 0.2, 0.1, "px")])
    line = capsys.readouterr().out.strip()
    assert line.startswith("FAIL") and "rms" in line and "<= 0.1 px" in line
