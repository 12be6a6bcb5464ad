"""Work on threads, in order: a task over a list of items with a bounded number in flight."""

from __future__ import annotations

from collections import deque
from concurrent.futures import ThreadPoolExecutor

from tqdm.auto import tqdm

__all__ = ["run_in_order"]


def run_in_order(
    task, items: list, label: str, progress: bool, workers: int, unit: str = "frame"
) -> list:
    """``task(item)`` for every item (a frame, a block), ``workers`` at a time on threads,
    the results in order, behind a progress bar (none when there are no items).

    Threads suffice for the work this runs: numpy, compiled loops and decompression, which
    release the GIL. At most twice ``workers`` items are in flight, so memory stays
    bounded; with one worker the items run in the calling thread (profilers and
    debuggers see the work).

    Examples
    --------
    >>> run_in_order(lambda x: x * x, [1, 2, 3], "squares", progress=False, workers=2)
    [1, 4, 9]
    """
    results = []
    # No bar for no items (a scan with no stored frames to read back): "0frame" says nothing.
    with tqdm(total=len(items), desc=label, unit=unit, disable=not progress or not items) as bar:
        if workers == 1:
            for item in items:
                results.append(task(item))
                bar.update()
            return results
        with ThreadPoolExecutor(max_workers=workers) as pool:
            pending: deque = deque()
            for item in items:
                pending.append(pool.submit(task, item))
                if len(pending) >= 2 * workers:
                    results.append(pending.popleft().result())
                    bar.update()
            while pending:
                results.append(pending.popleft().result())
                bar.update()
    return results
