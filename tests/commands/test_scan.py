"""``sassi-bench scan``'s closing lines: the deblur's parameter to three digits, and a next
command the CLI takes."""

from __future__ import annotations

import shlex
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from sassi_bench.commands import build_parser
from sassi_bench.commands.scan import _band_psnr_png, next_step
from sassi_bench.spectra.regularisation import RegularisationChoice


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


def test_the_band_psnr_line_names_the_deblurs_parameter_to_three_digits(tmp_path, capsys):
    lam = np.linspace(400.0, 700.0, 31)
    scan = SimpleNamespace(
        wavelengths_nm=lam, band_noise_psnr_db=np.full(lam.size, 40.0),
        cube=np.ones((2, 2, lam.size)),
        deblur=RegularisationChoice("discrepancy", "smoothness", 6.004512),
    )  # fmt: skip
    png = _band_psnr_png(SimpleNamespace(scan=scan), tmp_path / "cube.nc")
    printed = capsys.readouterr().out
    assert png == tmp_path / "cube-band-psnr.png" and png.is_file()
    assert printed.endswith("; the deblur's smoothness 6, chosen by the discrepancy rule\n"), (
        printed
    )
    assert "6.0045" not in printed
