"""Telling a full disk from other write failures, and saying what to do about it.

A calibration run at prototype scale stores gigabytes of frames; the disk filling up
half-way is an ordinary event on a lab PC, not a bug, so it gets a one-line error with
the free space and the fix instead of a storage library's traceback.

Examples
--------
>>> import errno
>>> is_disk_full(OSError(errno.ENOSPC, "No space left on device"))
True
>>> is_disk_full(OSError(errno.EACCES, "Permission denied"))
False
"""

from __future__ import annotations

import errno
import shutil
from pathlib import Path

__all__ = ["DISK_FULL_FIX", "disk_full_cause", "free_bytes", "is_disk_full"]

#: What a user does about a full disk (frames and bundles already stored are kept).
DISK_FULL_FIX = (
    "free space on that disk ('sassi-bench data clean' lists what no published bundle "
    "needs), or keep the data on a larger one (--data or SASSI_BENCH_DATA), then run it "
    "again: what is already stored is kept"
)


def is_disk_full(exc: BaseException) -> bool:
    """Whether ``exc`` is a write refused for lack of space (or of the user's quota).

    Examples
    --------
    >>> is_disk_full(ValueError("no"))
    False
    """
    return isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT)


def free_bytes(path: Path) -> int | None:
    """Free bytes on the disk holding ``path`` (its nearest existing folder), or None.

    Examples
    --------
    >>> free_bytes(Path(".")) > 0
    True
    """
    for folder in (path, *path.parents):
        try:
            return shutil.disk_usage(folder).free
        except OSError:
            continue
    return None


def disk_full_cause(path: Path) -> str:
    """The cause of a full-disk error, naming the folder and the free space left.

    Examples
    --------
    >>> disk_full_cause(Path(".")).startswith("the disk holding . is full")
    True
    """
    free = free_bytes(path)
    left = "" if free is None else f" ({free / 1e6:.0f} MB free)"
    return f"the disk holding {path} is full{left}"
