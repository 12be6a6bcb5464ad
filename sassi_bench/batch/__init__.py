"""Batches of sessions on dask.distributed: one task per session, a local cluster by default.

:func:`run_batch` assembles (or validates) many pinhole-scan sessions at once, on a
``LocalCluster`` sized to the machine or on a lab's scheduler; finished outputs are
skipped when run again, and a failed session is reported without stopping the others.
"""

from sassi_bench.batch.run import BatchResult, run_batch
from sassi_bench.batch.select import select_sessions
from sassi_bench.batch.tasks import SessionResult, TaskSpec

__all__ = ["BatchResult", "SessionResult", "TaskSpec", "run_batch", "select_sessions"]
