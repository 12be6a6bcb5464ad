"""Atomic writes: all or nothing under the final name, never a replaced file unless asked."""

from __future__ import annotations

import os
import stat

import pytest

from sassi_bench._shared.atomic import (
    atomic_path,
    atomic_write_bytes,
    atomic_write_text,
    fsync_dir,
    temporary_sibling,
)


class WriterCrash(RuntimeError):
    pass


def test_a_writer_failing_midway_leaves_no_partial_file(tmp_path):
    target = tmp_path / "cube.mat"
    with pytest.raises(WriterCrash), atomic_path(target, overwrite=False) as temporary:
        with open(temporary, "xb") as fh:
            fh.write(b"half of the planes")
        raise WriterCrash("the stream stopped")
    assert not target.exists()
    assert list(tmp_path.iterdir()) == []  # the temporary file is gone too


def test_a_failing_writer_keeps_the_old_file(tmp_path):
    target = atomic_write_text(tmp_path / "LATEST", "v0001\n", overwrite=True)
    with pytest.raises(WriterCrash), atomic_path(target, overwrite=True) as temporary:
        temporary.write_text("v00")
        raise WriterCrash("killed")
    assert target.read_text() == "v0001\n"
    assert [p.name for p in tmp_path.iterdir()] == ["LATEST"]


def test_the_final_name_appears_only_when_the_block_ends(tmp_path):
    target = tmp_path / "out.nc"
    with atomic_path(target, overwrite=False) as temporary:
        temporary.write_bytes(b"data")
        assert not target.exists()
        assert temporary.parent == tmp_path and temporary.name.startswith(".out.nc.")
    assert target.read_bytes() == b"data"
    assert not temporary.exists()


def test_overwrite_false_refuses_an_existing_file(tmp_path):
    target = atomic_write_bytes(tmp_path / "a.bin", b"first", overwrite=False)
    with pytest.raises(FileExistsError, match="already exists and was not replaced"):
        atomic_write_bytes(target, b"second", overwrite=False)
    assert target.read_bytes() == b"first"
    assert [p.name for p in tmp_path.iterdir()] == ["a.bin"]


def test_overwrite_false_refuses_a_file_that_appears_during_the_write(tmp_path):
    target = tmp_path / "a.bin"
    with (
        pytest.raises(FileExistsError),
        atomic_path(target, overwrite=False) as temporary,
    ):
        temporary.write_bytes(b"mine")
        target.write_bytes(b"another process")
    assert target.read_bytes() == b"another process"


def test_overwrite_false_without_hard_links_still_refuses(tmp_path, monkeypatch):
    def no_links(src, dst):
        raise PermissionError("this file system has no hard links")

    monkeypatch.setattr(os, "link", no_links)
    target = atomic_write_bytes(tmp_path / "a.bin", b"first", overwrite=False)
    assert target.read_bytes() == b"first"
    with pytest.raises(FileExistsError):
        atomic_write_bytes(target, b"second", overwrite=False)
    assert target.read_bytes() == b"first"


def test_overwrite_true_replaces(tmp_path):
    target = atomic_write_text(tmp_path / "LATEST", "v0001\n", overwrite=True)
    atomic_write_text(target, "v0002\n", overwrite=True)
    assert target.read_text() == "v0002\n"


def test_text_is_utf8_by_default(tmp_path):
    target = atomic_write_text(tmp_path / "note.txt", "5 µm\n", overwrite=False)
    assert target.read_bytes() == "5 µm\n".encode()


def test_new_files_get_the_umask_mode_not_a_private_one(tmp_path):
    old = os.umask(0o002)
    try:
        target = atomic_write_bytes(tmp_path / "shared.bin", b"x", overwrite=False)
    finally:
        os.umask(old)
    assert stat.S_IMODE(target.stat().st_mode) == 0o664


def test_the_folder_is_synced_after_the_rename(tmp_path, monkeypatch):
    synced = []
    real_fsync = os.fsync

    def recording_fsync(fd):
        synced.append(os.path.realpath(f"/proc/self/fd/{fd}"))
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", recording_fsync)
    atomic_write_bytes(tmp_path / "a.bin", b"x", overwrite=False)
    assert len(synced) == 2 and synced[-1] == os.path.realpath(tmp_path)


def test_fsync_dir_tolerates_folders_it_cannot_sync(tmp_path, monkeypatch):
    def refuse(fd):
        raise OSError("directory fsync not supported")

    monkeypatch.setattr(os, "fsync", refuse)
    fsync_dir(tmp_path)  # no error
    fsync_dir(tmp_path / "missing")


def test_temporary_names_are_hidden_and_distinct(tmp_path):
    names = {temporary_sibling(tmp_path / "v0001").name for _ in range(100)}
    assert len(names) == 100
    assert all(name.startswith(".v0001.") and name.endswith(".tmp") for name in names)
