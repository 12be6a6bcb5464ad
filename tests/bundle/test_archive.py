"""Zip export / import: round trip, verification, and hostile archives."""

from __future__ import annotations

import stat
import zipfile
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.bundle import (
    BundleError,
    BundleIntegrityError,
    UnsafeArchiveError,
    export_zip,
    import_zip,
    load,
    verify_zip,
)
from sassi_bench.bundle.layout import LATEST_LOCK_NAME


def test_round_trip(published: Path, tmp_path: Path):
    out = export_zip(published, tmp_path / "sim-v0001.zip")
    with zipfile.ZipFile(out) as archive:
        names = archive.namelist()
    assert names[:2] == ["manifest.json", "manifest.sha256"]
    assert "arrays/dispersion_x_coeffs.npy" in names and "report/summary.txt" in names
    other_root = tmp_path / "elsewhere"
    result = import_zip(out, data=other_root)
    assert result.created and result.path == other_root / "sim" / "v0001"
    a, b = load(published), load(result.path)
    np.testing.assert_array_equal(
        a.slm_to_camera(5, 7, a.wavelengths), b.slm_to_camera(5, 7, b.wavelengths)
    )
    assert (other_root / "sim" / "LATEST").read_text().strip() == "v0001"
    assert verify_zip(out) == tuple(sorted(names))


def test_export_is_deterministic_and_refuses_to_overwrite(published: Path, tmp_path: Path):
    first = export_zip(published, tmp_path / "a.zip")
    second = export_zip(published, tmp_path / "b.zip")
    assert first.read_bytes() == second.read_bytes()
    with pytest.raises(BundleError, match="already exists"):
        export_zip(published, first)


def test_import_same_bundle_twice_is_a_no_op(published: Path, tmp_path: Path, data_root: Path):
    out = export_zip(published, tmp_path / "b.zip")
    result = import_zip(out, data=data_root)
    assert result.created is False and result.path == published


def test_import_never_overwrites_a_different_version(tmp_path: Path, synthetic):
    lab_a = synthetic.publish_synthetic(tmp_path / "lab_a")
    synthetic.publish_synthetic(tmp_path / "lab_b", procedure={"different": True})
    out = export_zip(lab_a, tmp_path / "a.zip")
    before = (tmp_path / "lab_b" / "sim" / "v0001" / "manifest.json").read_bytes()
    with pytest.raises(BundleError, match="already exists with different content"):
        import_zip(out, data=tmp_path / "lab_b")
    assert (tmp_path / "lab_b" / "sim" / "v0001" / "manifest.json").read_bytes() == before
    assert not [
        p
        for p in (tmp_path / "lab_b" / "sim").iterdir()
        if p.name.startswith(".") and p.name != LATEST_LOCK_NAME
    ]


def test_import_refuses_another_rig(published: Path, tmp_path: Path):
    out = export_zip(published, tmp_path / "b.zip")
    with pytest.raises(BundleError, match="rig 'sim', not 'lab2'"):
        import_zip(out, rig="lab2", data=tmp_path / "new")


def make_zip(path: Path, entries: dict[str, bytes], symlinks: tuple[str, ...] = ()) -> Path:
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in entries.items():
            info = zipfile.ZipInfo(name)
            mode = stat.S_IFLNK | 0o777 if name in symlinks else stat.S_IFREG | 0o644
            info.external_attr = mode << 16
            archive.writestr(info, data)
    return path


def bundle_entries(published: Path) -> dict[str, bytes]:
    return {
        p.relative_to(published).as_posix(): p.read_bytes()
        for p in sorted(published.rglob("*"))
        if p.is_file()
    }


@pytest.mark.parametrize(
    ("evil_name", "match"),
    [
        ("../escape.txt", r"'\.\.'"),
        ("arrays/../../escape.npy", r"'\.\.'"),
        ("/etc/passwd", "absolute path"),
        ("C:/Windows/evil.dll", "absolute path"),
        ("arrays\\..\\evil.npy", "backslashes"),
        ("secrets.txt", "not an expected name"),
        ("arrays/sub/deep.npy", "not an expected name"),
        ("arrays//x.npy", "empty"),
        ("extra/", "folder the bundle format does not have"),
    ],
)
def test_malicious_zip_is_rejected(published: Path, tmp_path: Path, evil_name: str, match: str):
    entries = bundle_entries(published)
    entries[evil_name] = b"pwned"
    evil = make_zip(tmp_path / "evil.zip", entries)
    target = tmp_path / "victim"
    with pytest.raises(UnsafeArchiveError, match=match):
        import_zip(evil, data=target)
    assert not (tmp_path / "escape.txt").exists()
    assert not (target / "sim" / "v0001").exists()
    with pytest.raises(UnsafeArchiveError):
        verify_zip(evil)


def test_symlink_entry_is_rejected(published: Path, tmp_path: Path):
    entries = bundle_entries(published)
    entries["arrays/response.npy"] = b"/etc/passwd"
    evil = make_zip(tmp_path / "link.zip", entries, symlinks=("arrays/response.npy",))
    with pytest.raises(UnsafeArchiveError, match="symbolic link"):
        import_zip(evil, data=tmp_path / "victim")


def test_duplicate_entry_is_rejected(published: Path, tmp_path: Path):
    entries = bundle_entries(published)
    path = make_zip(tmp_path / "dup.zip", entries)
    with (
        pytest.warns(UserWarning, match="Duplicate name"),
        zipfile.ZipFile(path, "a") as archive,
    ):
        archive.writestr("arrays/response.npy", b"second copy")
    with pytest.raises(UnsafeArchiveError, match="appears twice"):
        import_zip(path, data=tmp_path / "victim")


def test_size_limit(published: Path, tmp_path: Path):
    out = export_zip(published, tmp_path / "b.zip")
    with pytest.raises(UnsafeArchiveError, match="bytes allowed"):
        import_zip(out, data=tmp_path / "victim", max_bytes=1000)


def test_corrupted_content_in_zip_is_detected(published: Path, tmp_path: Path):
    entries = bundle_entries(published)
    data = bytearray(entries["arrays/bin_edges_nm.npy"])
    data[-1] ^= 0xFF
    entries["arrays/bin_edges_nm.npy"] = bytes(data)
    bad = make_zip(tmp_path / "bad.zip", entries)
    target = tmp_path / "victim"
    with pytest.raises(BundleIntegrityError, match=r"arrays/bin_edges_nm\.npy"):
        import_zip(bad, data=target)
    assert not (target / "sim" / "v0001").exists()
    assert not [
        p
        for p in (target / "sim").iterdir()
        if p.name.startswith(".") and p.name != LATEST_LOCK_NAME
    ]


def test_not_a_zip(tmp_path: Path):
    junk = tmp_path / "junk.zip"
    junk.write_bytes(b"definitely not a zip")
    with pytest.raises(BundleIntegrityError, match="not a readable zip"):
        import_zip(junk, data=tmp_path / "victim")
    with pytest.raises(BundleError, match="does not exist"):
        import_zip(tmp_path / "missing.zip", data=tmp_path / "victim")


def _flip(path: Path, offset: int = -1) -> bytes:
    """Flip one bit of one byte of a file (a real flipped byte); the original bytes."""
    raw = path.read_bytes()
    damaged = bytearray(raw)
    damaged[offset] ^= 0x01
    path.write_bytes(bytes(damaged))
    return raw


@pytest.mark.parametrize("damaged", ["arrays/dispersion_x_coeffs.npy", "manifest.json"])
def test_import_repairs_a_damaged_copy_from_its_verified_zip(
    damaged: str, published: Path, tmp_path: Path, data_root: Path
):
    from sassi_bench.bundle import verify

    out = export_zip(published, tmp_path / "b.zip")
    original = _flip(published / damaged, offset=-3)
    with pytest.raises(BundleIntegrityError) as failure:
        verify(published)
    assert damaged in str(failure.value) and "bundle import" in str(failure.value)
    result = import_zip(out, data=data_root)
    assert (result.created, result.repaired, result.path) == (False, (damaged,), published)
    assert (published / damaged).read_bytes() == original
    verify(published)
    assert import_zip(out, data=data_root).repaired == ()  # intact now: nothing to do


def test_the_command_line_repairs_a_flipped_byte(published: Path, tmp_path: Path, capsys):
    from sassi_bench.commands import main

    out = tmp_path / "b.zip"
    assert main(["bundle", "export", str(published), "--zip", str(out)]) == 0
    _flip(published / "arrays" / "dispersion_x_coeffs.npy")
    assert main(["bundle", "verify", str(published)]) == 1
    assert "arrays/dispersion_x_coeffs.npy" in capsys.readouterr().out
    assert main(["bundle", "import", str(out), "--data", str(published.parents[1])]) == 0
    printed = capsys.readouterr().out
    assert "repaired" in printed and "arrays/dispersion_x_coeffs.npy" in printed
    assert main(["bundle", "verify", str(published)]) == 0
    assert capsys.readouterr().out.startswith("OK")
