"""``sassi-bench bundle ...`` through the real entry point ``sassi_bench.commands.main``."""

from __future__ import annotations

import zipfile
from pathlib import Path

import pytest

from sassi_bench.commands import main


def run(capsys, *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_list(capsys, data_root: Path, synthetic):
    code, out, _ = run(capsys, "bundle", "list", "--data", str(data_root))
    assert code == 0 and "no calibration bundles" in out
    synthetic.publish_synthetic(data_root)
    synthetic.publish_synthetic(data_root, quality=synthetic.failing_quality(), allow_failed=True)
    code, out, _ = run(capsys, "bundle", "list", "--rig", "sim", "--data", str(data_root))
    assert code == 0
    lines = out.splitlines()
    assert lines[0].split() == ["RIG", "VERSION", "CREATED", "STATUS", "PARENT"]
    assert lines[1].split()[1:2] == ["v0001"] and "passed" in lines[1]
    assert lines[2].split()[1] == "v0002*" and "FAILED(override)" in lines[2]
    assert lines[2].split()[-1] == "v0001"


def test_show(capsys, published: Path, data_root: Path):
    code, out, _ = run(capsys, "bundle", "show", "v0001", "--rig", "sim", "--data", str(data_root))
    assert code == 0
    assert "sim/v0001" in out and "status      passed" in out
    assert "68 bins, 400.0-700.0 nm" in out
    assert "sigma" in out and "window +/-2.5 sigma" in out
    assert "homography calibrated (rms 0.41 px)" in out
    assert "PASS  dispersion_rms: 0.08 px (tolerance <= 0.25 px)" in out
    code, out_latest, _ = run(capsys, "bundle", "show", "--data", str(data_root))
    assert code == 0 and "sim/v0001" in out_latest
    code, out_path, _ = run(capsys, "bundle", "show", str(published))
    assert code == 0 and "sim/v0001" in out_path


def test_show_missing_version_is_a_user_error(capsys, published: Path, data_root: Path):
    code, _, err = run(capsys, "bundle", "show", "v0007", "--data", str(data_root))
    assert code == 2 and "no version v0007" in err and "Fix:" in err


def test_verify_ok_and_failure(capsys, published: Path, tmp_path: Path):
    code, out, _ = run(capsys, "bundle", "verify", str(published))
    assert code == 0 and out.startswith("OK")
    target = published / "arrays" / "bin_edges_nm.npy"
    data = bytearray(target.read_bytes())
    data[100] ^= 0x10
    target.write_bytes(bytes(data))
    code, out, _ = run(capsys, "bundle", "verify", str(published))
    assert code != 0
    assert out.startswith("FAILED") and "arrays/bin_edges_nm.npy" in out and "SHA-256" in out
    code, _, err = run(capsys, "bundle", "verify", str(tmp_path / "nowhere"))
    assert code == 2 and "not a bundle folder" in err


def test_diff(capsys, data_root: Path, synthetic):
    synthetic.publish_synthetic(data_root)
    synthetic.publish_synthetic(data_root, procedure={**synthetic.PROCEDURE, "note": "v2"})
    code, out, _ = run(capsys, "bundle", "diff", "v0001", "latest", "--data", str(data_root))
    assert code == 0
    assert "bundle diff sim/v0001 -> sim/v0002" in out
    assert "wavelength map: shift max 0 px" in out
    assert "note: '<absent>' -> 'v2'" in out


def test_export_import_and_verify_zip(capsys, published: Path, tmp_path: Path):
    out_zip = tmp_path / "sim-v0001.zip"
    code, out, _ = run(capsys, "bundle", "export", str(published), "--zip", str(out_zip))
    assert code == 0 and out_zip.is_file()
    code, out, _ = run(capsys, "bundle", "verify", str(out_zip))
    assert code == 0 and out.startswith("OK")
    other = tmp_path / "other"
    code, out, _ = run(capsys, "bundle", "import", str(out_zip), "--data", str(other))
    assert code == 0 and "imported" in out
    assert (other / "sim" / "v0001" / "manifest.json").is_file()
    code, out, _ = run(capsys, "bundle", "import", str(out_zip), "--data", str(other))
    assert code == 0 and "already present and verified" in out
    code, _, err = run(capsys, "bundle", "export", str(published), "--zip", str(out_zip))
    assert code == 2 and "already exists" in err


def test_import_rejects_traversal(capsys, published: Path, tmp_path: Path):
    evil = tmp_path / "evil.zip"
    with zipfile.ZipFile(evil, "w") as archive:
        for p in published.rglob("*"):
            if p.is_file():
                archive.write(p, p.relative_to(published).as_posix())
        archive.writestr("../../outside.txt", "pwned")
    code, _, err = run(capsys, "bundle", "import", str(evil), "--data", str(tmp_path / "d"))
    assert code == 2 and "'..'" in err
    assert not (tmp_path / "outside.txt").exists()


def test_bundle_requires_a_subcommand(capsys):
    with pytest.raises(SystemExit) as info:
        main(["bundle"])
    assert info.value.code == 2


def test_every_subcommand_names_a_bundle_the_same_way(capsys, data_root: Path, synthetic):
    synthetic.publish_synthetic(data_root)
    synthetic.publish_synthetic(data_root)
    data = ["--data", str(data_root)]
    for ref in ("latest", "v0002", "2", str(data_root / "sim" / "v0002")):
        code, out, err = run(capsys, "bundle", "verify", ref, "--rig", "sim", *data)
        assert code == 0 and "v0002" in out, (ref, err)
        code, out, _ = run(capsys, "bundle", "show", ref, "--rig", "sim", *data)
        assert code == 0 and out.startswith("sim/v0002")
    code, out, _ = run(capsys, "bundle", "verify", *data)  # latest of the default rig
    assert code == 0 and "v0002" in out
    code, _, err = run(capsys, "bundle", "verify", "v0009", *data)
    assert code == 2 and "published: v0001, v0002" in err
    code, _, err = run(capsys, "bundle", "verify", "no/such/folder", *data)
    assert code == 2 and "not a version (latest, v0003, 3) and not a bundle folder" in err


def test_bundle_options_of_other_commands_use_the_same_rule(data_root: Path, synthetic):
    import argparse

    from sassi_bench.commands import build_parser
    from sassi_bench.commands.options import add_bundle_options, bundle_from_args

    synthetic.publish_synthetic(data_root)
    parser = argparse.ArgumentParser()
    add_bundle_options(parser)
    parser.add_argument("--data")
    for ref in (["--bundle", "1"], ["--bundle", "v0001"], [], ["--bundle", "latest"]):
        args = parser.parse_args([*ref, "--data", str(data_root)])
        assert bundle_from_args(args, "sim", step="scan").version == "v0001"
    args = parser.parse_args(["--bundle", str(data_root / "sim" / "v0001"), "--bundle-rig", "x"])
    assert bundle_from_args(args, "sim", step="scan").version == "v0001"
    # Every command with a bundle option accepts --bundle and --bundle-rig.
    for command in (["scan", "--out", "c.nc"], ["calibrate", "response"],
                    ["calibrate", "guide"], ["validate", "macbeth", "--out", "r"]):  # fmt: skip
        args = build_parser().parse_args([*command, "--bundle", "v0001", "--bundle-rig", "sim"])
        assert (args.bundle, args.bundle_rig) == ("v0001", "sim")


def test_list_names_an_unreadable_manifest_and_a_latest_naming_a_missing_version(
    capsys, data_root: Path, synthetic
):
    synthetic.publish_synthetic(data_root)
    synthetic.publish_synthetic(data_root)
    manifest = data_root / "sim" / "v0001" / "manifest.json"
    manifest.write_bytes(manifest.read_bytes()[:40])
    (data_root / "sim" / "LATEST").write_text("v0009\n")
    code, out, _ = run(capsys, "bundle", "list", "--data", str(data_root))
    assert code == 0
    lines = out.splitlines()
    assert "UNREADABLE" in lines[1] and lines[2].split()[1] == "v0002*"
    assert "UNREADABLE sim/v0001: manifest.json is not JSON (" in out
    assert "no command loads this bundle. Fix: restore the folder" in out
    assert "bundle verify v0001 --rig sim` checks it" in out
    latest = data_root / "sim" / "LATEST"
    assert f"warning: {latest} names 'v0009', which is not there; `latest` means v0002" in out
    assert "bundle import ZIP" in out


def test_a_command_taking_the_latest_bundle_warns_of_a_broken_latest(
    capsys, data_root: Path, synthetic
):
    import argparse

    from sassi_bench.commands.options import bundle_from_args

    synthetic.publish_synthetic(data_root)
    (data_root / "sim" / "LATEST").write_text("v0007\n")
    args = argparse.Namespace(bundle=None, bundle_rig=None, data=str(data_root))
    assert bundle_from_args(args, "sim", step="scan").version == "v0001"
    out = capsys.readouterr().out
    assert "names 'v0007', which is not there; `latest` means v0001" in out
    assert out.splitlines()[1].startswith("warning: ")
