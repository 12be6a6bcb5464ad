"""Capture a pinhole scan and assemble it while it is captured.

:func:`capture_scan` runs a scan session's missing steps and hands every frame, as soon as
it is stored, to the scan's reading pass
(:class:`~sassi_bench.spectra.scan.ScanAssembly`, on a worker thread of a
:class:`~sassi_bench.acquire.frame_feed.FrameFeed`), so that pass overlaps the capture
and no frame is read back; frames stored before (a resumed capture) are read back first,
on a thread per CPU. Only the spectra pass and the deblur wait for the last frame: they
need the background, which every frame adds to. The reading pass's sums are exact, so
the cube is the one :func:`~sassi_bench.reduce.scan.assemble_scan` makes of the
finished session, wherever a capture was interrupted.
"""

from __future__ import annotations

from collections.abc import Sequence

from sassi_bench._shared.memory import release_memory
from sassi_bench.acquire.frame_feed import FrameFeed
from sassi_bench.acquire.runner import run_plan
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.reduce.scan import finish_scan, read_stored, scan_assembly
from sassi_bench.rig.rig import Rig
from sassi_bench.spectra.scan import ScanCube

__all__ = ["capture_scan"]


def capture_scan(
    rig: Rig,
    session: Session,
    bundle: CalibrationBundle,
    *,
    roi: Sequence[int] | None = None,
    deblur: bool = True,
    keep_raw: bool = False,
    row_mixture: bool = True,
    progress: bool = True,
) -> ScanCube:
    """Capture what a scan session misses and assemble the scan as its frames are stored.

    Parameters
    ----------
    rig
        Device handles.
    session
        A pinhole-scan session (:func:`~sassi_bench.acquire.scan_plans.scan_plan`), new or
        partly captured.
    bundle, roi, deblur, keep_raw, row_mixture
        As for :func:`~sassi_bench.reduce.scan.assemble_scan`.
    progress
        Show progress bars.

    Returns
    -------
    ScanCube

    Examples
    --------
    >>> scan = capture_scan(rig, session, bundle, keep_raw=True)  # doctest: +SKIP
    """
    assembly = scan_assembly(
        session, bundle, roi=roi, deblur=deblur, keep_raw=keep_raw, row_mixture=row_mixture
    )
    stored = session.completed
    read_stored(assembly, session, [i for i in assembly.steps if i in stored], progress=progress)
    todo = [i for i in assembly.steps if i not in stored]
    with FrameFeed(session, todo, assembly.read, label="scan") as feed:
        run_plan(rig, session.plan, feed.tee(), progress=progress)
        feed.finish()
    release_memory()  # the reading pass's per-frame buffers, before the cube's work
    return finish_scan(assembly, session, progress=progress)
