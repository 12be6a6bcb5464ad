"""Give the memory a finished stage freed back to the system.

A stage of the chain frees gigabytes of arrays when it ends (a prototype scan's cube and
column sums, the decoders' frames), but the C allocator keeps much of what worker threads
freed in their own arenas, so the process's resident memory stays high into the next stage
(measured: ``docs/notes/2026-12-01-measured-in-code-comments.md``). On glibc,
``malloc_trim`` returns that free memory; elsewhere this does nothing.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import functools
import gc

__all__ = ["release_memory"]


@functools.cache
def _trim():
    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):  # not glibc
        return None


def release_memory() -> None:
    """Collect garbage and return the allocator's free memory to the system (glibc).

    Examples
    --------
    >>> release_memory()
    """
    gc.collect()
    trim = _trim()
    if trim is not None:
        trim(0)
