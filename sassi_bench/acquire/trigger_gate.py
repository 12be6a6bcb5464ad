"""The exposure trigger armed around captures made outside a plan.

On a real bench a camera on a line trigger exposes only for the SLM pulses the trigger
passes; :func:`~sassi_bench.acquire.runner.run_plan` arms it for a plan's frames, and
every other capture (auto-exposure, quick-look views, live previews) goes through
:func:`armed` so it does not wait for a pulse that never comes.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

from sassi_bench.rig import Rig

__all__ = ["armed"]


@contextlib.contextmanager
def armed(rig: Rig) -> Iterator[None]:
    """Arm ``rig``'s trigger for a block; leave it as it was found.

    Examples
    --------
    >>> from sassi_bench import open_rig
    >>> rig = open_rig("sim")
    >>> with armed(rig):
    ...     rig.trigger.armed
    True
    >>> rig.trigger.armed
    False
    """
    if rig.trigger.armed:
        yield
        return
    rig.trigger.arm()
    try:
        yield
    finally:
        rig.trigger.disarm()
