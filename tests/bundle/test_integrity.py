"""Every corruption of a published bundle is detected, and the error names the file."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from sassi_bench.bundle import BundleIntegrityError, BundleSchemaError, load, verify
from sassi_bench.bundle.integrity import format_manifest_checksum, sha256_bytes

BUNDLE_FILES = [
    "manifest.json",
    "arrays/bin_centres_nm.npy",
    "arrays/bin_edges_nm.npy",
    "arrays/bin_resolution_nm.npy",
    "arrays/dispersion_x_coeffs.npy",
    "arrays/dispersion_y_coeffs.npy",
    "arrays/guide_to_slm.npy",
    "arrays/laser_residuals_px.npy",
    "arrays/response.npy",
    "report/summary.txt",
]


def flip_byte(path: Path, offset: int) -> None:
    data = bytearray(path.read_bytes())
    data[offset % len(data)] ^= 0x01
    path.write_bytes(bytes(data))


@pytest.mark.parametrize("file", BUNDLE_FILES)
@pytest.mark.parametrize("where", ["start", "middle", "end"])
def test_flipped_byte_is_detected_and_named(published: Path, file: str, where: str):
    target = published / file
    size = target.stat().st_size
    flip_byte(target, {"start": 0, "middle": size // 2, "end": size - 1}[where])
    with pytest.raises(BundleIntegrityError) as info:
        load(published)
    assert info.value.file == file
    assert file in str(info.value) and "Fix:" in str(info.value)
    with pytest.raises(BundleIntegrityError):
        verify(published)


@pytest.mark.parametrize("file", ["manifest.json", "arrays/dispersion_x_coeffs.npy"])
def test_truncated_file_is_detected(published: Path, file: str):
    target = published / file
    target.write_bytes(target.read_bytes()[:-9])
    with pytest.raises(BundleIntegrityError, match=file) as info:
        load(published)
    assert info.value.file == file


def test_empty_array_file_is_detected(published: Path):
    (published / "arrays/response.npy").write_bytes(b"")
    with pytest.raises(BundleIntegrityError, match=r"arrays/response\.npy.*0 bytes"):
        load(published)


@pytest.mark.parametrize("file", ["manifest.json", "manifest.sha256", "arrays/guide_to_slm.npy"])
def test_missing_file_is_detected(published: Path, file: str):
    (published / file).unlink()
    with pytest.raises(BundleIntegrityError, match=f"{file}: is missing"):
        load(published)


def test_malformed_checksum_file(published: Path):
    (published / "manifest.sha256").write_text("not a checksum\n")
    with pytest.raises(BundleIntegrityError, match=r"manifest\.sha256") as info:
        load(published)
    assert info.value.file == "manifest.sha256"


def test_extra_file_is_refused(published: Path):
    (published / "arrays" / "sneaky.npy").write_bytes(b"x")
    with pytest.raises(BundleIntegrityError, match=r"arrays/sneaky\.npy: is not listed"):
        load(published)
    (published / "arrays" / "sneaky.npy").unlink()
    (published / "notes").mkdir()
    with pytest.raises(BundleIntegrityError, match="notes/"):
        load(published)


@pytest.mark.skipif(not hasattr(os, "symlink"), reason="needs symlinks")
def test_symlinked_array_is_refused(published: Path, tmp_path: Path):
    target = published / "arrays" / "response.npy"
    outside = tmp_path / "outside.npy"
    shutil.copy(target, outside)
    target.unlink()
    target.symlink_to(outside)
    with pytest.raises(BundleIntegrityError, match="symbolic link"):
        load(published)


def test_renamed_version_folder_is_refused(published: Path):
    renamed = published.with_name("v0042")
    published.rename(renamed)
    with pytest.raises(
        BundleIntegrityError, match="records version v0001 but the folder is named v0042"
    ):
        load(renamed)
    # Outside the rig layout (any other folder name) the bundle still loads.
    moved = renamed.with_name("exported-copy")
    renamed.rename(moved)
    assert load(moved).version == "v0001"


def rewrite_manifest(path: Path, manifest: dict) -> None:
    """Replace manifest.json and its checksum consistently (simulating a forged manifest)."""
    raw = json.dumps(manifest).encode()
    (path / "manifest.json").write_bytes(raw)
    (path / "manifest.sha256").write_text(format_manifest_checksum(sha256_bytes(raw)))


def test_array_swapped_with_consistent_manifest_checksum_still_fails(published: Path):
    # Tamper with an array AND the manifest's checksum file: the per-array hash still catches it.
    np.save(published / "arrays/response.npy", np.ones(68))
    manifest = json.loads((published / "manifest.json").read_text())
    rewrite_manifest(published, manifest)
    with pytest.raises(BundleIntegrityError, match=r"arrays/response\.npy"):
        load(published)


def test_dtype_or_shape_mismatch_is_detected(published: Path):
    manifest = json.loads((published / "manifest.json").read_text())
    manifest["arrays"]["response"]["shape"] = [67]
    rewrite_manifest(published, manifest)
    with pytest.raises(BundleIntegrityError, match=r"arrays/response\.npy: holds <f8 \(68,\)"):
        load(published)


def test_cross_field_rules(published: Path):
    manifest = json.loads((published / "manifest.json").read_text())
    manifest["passed"] = False
    rewrite_manifest(published, manifest)
    with pytest.raises(BundleSchemaError, match="passed is False but the quality checks say True"):
        load(published)
    manifest["passed"] = True
    manifest["rig"]["slm"]["shape"] = [1, 1]
    rewrite_manifest(published, manifest)
    with pytest.raises(BundleSchemaError, match="rig_hash"):
        load(published)


def test_pickled_array_is_refused(published: Path):
    # An object array can only be stored with pickle; the loader must never unpickle it.
    path = published / "arrays/response.npy"
    np.save(path, np.array([{"evil": 1}], dtype=object), allow_pickle=True)
    raw = path.read_bytes()
    manifest = json.loads((published / "manifest.json").read_text())
    manifest["arrays"]["response"]["sha256"] = sha256_bytes(raw)
    rewrite_manifest(published, manifest)
    with pytest.raises(
        BundleIntegrityError, match=r"arrays/response\.npy: is not a readable \.npy"
    ):
        load(published)


def test_verify_lists_files(published: Path):
    files = verify(published)
    assert "manifest.json" in files and "arrays/response.npy" in files
    assert "report/summary.txt" in files
