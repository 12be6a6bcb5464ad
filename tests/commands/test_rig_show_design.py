"""``sassi-bench rig show`` on a rig described as an optical design."""

from sassi_bench.commands import main


def test_rig_show_draws_a_design_rig(design_rigs, tmp_path, capsys):
    design_rigs("singlet")  # traced once for the session (skips without optiland)
    out = tmp_path / "singlet.png"
    assert main(["rig", "show", "--rig", "sim-singlet", "--figure", str(out)]) == 0
    text = capsys.readouterr().out
    assert "design:" in text and "as designed:" in text and str(out) in text
    assert out.stat().st_size > 20_000  # four panels
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_rig_show_says_what_to_run_next(design_rigs, capsys):
    design_rigs("achromat")
    assert main(["rig", "show", "--rig", "sim-achromat"]) == 0
    assert "--figure sim-achromat.png" in capsys.readouterr().out


def test_a_parametric_rig_has_no_design_figure(tmp_path, capsys):
    assert main(["rig", "show", "--rig", "sim", "--figure", str(tmp_path / "x.png")]) == 0
    assert "no figure" in capsys.readouterr().out
    assert not (tmp_path / "x.png").exists()
