"""Fault-kit only (put on ``PYTHONPATH`` by ``fault_kit.kill_point`` for a file trigger):
every file written through :mod:`sassi_bench._shared.atomic` waits
``SASSI_FAULT_KIT_COMMIT_PAUSE_S`` seconds under its temporary name before it is moved
into place, so a trigger that watches for that name lands however fast the write is.
The write itself, and what a kill at that point leaves, are unchanged."""

import os

_PAUSE_S = float(os.environ.get("SASSI_FAULT_KIT_COMMIT_PAUSE_S", "0") or 0)

if _PAUSE_S > 0:
    import time

    from sassi_bench._shared import atomic

    _move_into_place = atomic._move_into_place

    def _paused_move_into_place(temporary, path, *, overwrite):
        time.sleep(_PAUSE_S)
        return _move_into_place(temporary, path, overwrite=overwrite)

    atomic._move_into_place = _paused_move_into_place
