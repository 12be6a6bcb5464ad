"""Telling a full disk from other write failures."""

from __future__ import annotations

import errno

from sassi_bench._shared.disk import disk_full_cause, free_bytes, is_disk_full


def test_a_full_disk_and_a_spent_quota_are_disk_full_and_nothing_else_is():
    assert is_disk_full(OSError(errno.ENOSPC, "No space left on device"))
    assert is_disk_full(OSError(errno.EDQUOT, "Disk quota exceeded"))
    assert not is_disk_full(OSError(errno.EACCES, "Permission denied"))
    assert not is_disk_full(FileNotFoundError(errno.ENOENT, "gone"))
    assert not is_disk_full(RuntimeError("No space left on device"))


def test_free_space_is_read_from_the_nearest_folder_that_exists(tmp_path):
    not_yet = tmp_path / "data" / "sessions" / "x"
    assert free_bytes(not_yet) == free_bytes(tmp_path) > 0
    cause = disk_full_cause(not_yet)
    assert cause.startswith(f"the disk holding {not_yet} is full (") and cause.endswith(" free)")
