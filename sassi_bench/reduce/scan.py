"""Pinhole-scan sessions into cubes on the SLM grid.

:func:`assemble_scan` reads a finished (or partly captured) scan session's frames on a
thread per CPU and assembles them (:class:`~sassi_bench.spectra.scan.ScanAssembly`);
the capture feeds the same assembly frame by frame as it stores them
(:func:`~sassi_bench.workflows.scan.capture_scan`), and both give the same cube bit for
bit. :class:`ScanRun` is a finished scan with its provenance, as a dataset.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

from sassi_bench._shared.threads import run_in_order
from sassi_bench.acquire.session import Session
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.spectra.scan import ScanAssembly, ScanCube

__all__ = ["ScanRun", "assemble_scan", "finish_scan", "read_stored", "scan_assembly"]


def scan_assembly(
    session: Session,
    bundle: CalibrationBundle,
    *,
    roi: Sequence[int] | None = None,
    deblur: bool = True,
    keep_raw: bool = False,
    unmixing: str = "mixed",
) -> ScanAssembly:
    """The assembly of a scan session's frames, before any frame is read.

    Parameters
    ----------
    session
        A pinhole-scan session, complete or still to be captured.
    bundle, roi, deblur, keep_raw, unmixing
        As for :func:`assemble_scan`.

    Returns
    -------
    ScanAssembly

    Examples
    --------
    Not run here (it needs captured sessions)::

        assembly = scan_assembly(session, bundle)
    """
    return ScanAssembly(
        session.plan, session.rig, bundle,
        roi=roi, deblur=deblur, keep_raw=keep_raw, unmixing=unmixing,
    )  # fmt: skip


def read_stored(
    assembly: ScanAssembly,
    session: Session,
    indices: Sequence[int],
    *,
    progress: bool = True,
    workers: int | None = None,
) -> None:
    """The reading pass of frames stored in ``session``, read back on ``workers`` threads
    (default: one per CPU).

    Examples
    --------
    Not run here (it needs captured sessions)::

        read_stored(assembly, session, sorted(session.completed))
    """
    workers = max(1, workers or os.cpu_count() or 1)

    def task(index: int) -> None:
        assembly.read(index, session.read_frame(index))

    with threadpool_limits(limits=1, user_api="blas"):
        run_in_order(task, list(indices), "scan frames", progress, workers)


def finish_scan(
    assembly: ScanAssembly,
    session: Session,
    *,
    progress: bool = True,
    workers: int | None = None,
) -> ScanCube:
    """The cube of every frame the assembly read; the closed-SLM frame is read back from
    the session first if the reading pass did not have it (its problems count too).

    Examples
    --------
    Not run here (it needs captured sessions)::

        scan = finish_scan(assembly, session)
    """
    closed = assembly.missing_closed
    if closed is not None and closed in session.completed:
        assembly.read(closed, session.read_frame(closed))
    return assembly.finish(progress=progress, workers=workers)


def assemble_scan(
    session: Session,
    bundle: CalibrationBundle,
    *,
    roi: Sequence[int] | None = None,
    deblur: bool = True,
    keep_raw: bool = False,
    unmixing: str = "mixed",
    progress: bool = True,
    workers: int | None = None,
) -> ScanCube:
    """Assemble a pinhole-scan session into a cube on the SLM grid.

    Every frame is read once. The reading pass adds the frame's pixels outside the
    predicted streaks to the background estimate and keeps the raw cell sums of its open
    pixels (linear in the frame) and their noise; the spectra pass then subtracts the
    background's cell sums and unmixes, without reading frames again. Only the camera rows
    that streaks can reach are processed.
    (:class:`~sassi_bench.spectra.scan.ScanAssembly` takes the frames one at a time, e.g.
    as they are captured.)

    Parameters
    ----------
    session
        A session of a :func:`~sassi_bench.acquire.scan_plans.scan_plan` (complete or not:
        missing frames leave their pixels flagged ``not_measured``).
    bundle
        The calibration bundle giving the streak geometry and blur.
    roi
        Optional (row0, col0, row1, col1) SLM region (end exclusive) to assemble.
    deblur
        Undo the spill of each bin into its neighbours along the streak (see
        :mod:`sassi_bench.spectra.deblur`), with the regularisation chosen from the scan.
    keep_raw
        Also keep every pixel's column sums before the deblur and their noise
        (:attr:`ScanCube.column_sums`, :attr:`ScanCube.noise_variance`), for spectra
        averaged before they are deblurred (the response, the Macbeth patches).
    unmixing
        How stacked pixels are unmixed
        (:data:`~sassi_bench.spectra.unmixing.ROW_UNMIXING_METHODS`): ``"mixed"``, each
        one's light in a bin's columns blurred across the streak as the mixture of the
        wavelengths that reach them (closer at the red end, about 1.6 times the CPU of the
        assembly), or ``"separable"``, each bin with its own blur alone.
    progress
        Show progress bars.
    workers
        Frames processed at once (threads; default: the number of CPUs).

    Returns
    -------
    ScanCube

    Examples
    --------
    Not run here (it needs captured sessions)::

        scan = assemble_scan(session, bundle)
        scan.cube.shape
        # (400, 640, 68)
    """
    assembly = scan_assembly(
        session, bundle, roi=roi, deblur=deblur, keep_raw=keep_raw, unmixing=unmixing
    )
    stored = [i for i in assembly.steps if i in session.completed]
    read_stored(assembly, session, stored, progress=progress, workers=workers)
    return finish_scan(assembly, session, progress=progress, workers=workers)


@dataclass
class ScanRun:
    """A finished scan: the assembled cube, whether it is in radiance, and its session."""

    scan: ScanCube
    radiance: bool
    session: Session
    bundle: CalibrationBundle

    def dataset(self):
        """The cube as an xarray Dataset with its provenance as attributes.

        Returns
        -------
        xarray.Dataset
            Dims (y, x, wavelength), divided by the bundle's response when ``radiance``;
            its attributes name the bundle, session, scene and light.

        Examples
        --------
        Not run here (it needs captured sessions)::

            run_scan(rig, bundle, scene="white").dataset()["radiance"].dims
            # ('y', 'x', 'wavelength')
        """
        from sassi_bench.spectra.cube_io import cube_dataset

        cube = self.scan
        if self.radiance:
            cube = ScanCube(**{**cube.__dict__, "cube": _divided(cube.cube, self.bundle.response)})
        units = (
            "relative photon radiance per bin" if self.radiance else "camera ADU per second per bin"
        )
        attrs: dict[str, Any] = {
            "bundle_version": self.bundle.version,
            "bundle_rig": self.bundle.rig_name,
            "session_id": self.session.id,
            "session_sha256": self.session.sha256(),
            "scene": str(self.session.plan.parameters.get("scene", "")),
            "light": str(self.session.plan.parameters.get("light", "")),
        }
        response = self.bundle.response if self.radiance else None
        return cube_dataset(cube, units=units, response=response, attrs=attrs)


def _divided(cube: np.ndarray, response: np.ndarray, rows: int = 64) -> np.ndarray:
    """``(cube / response).astype(float32)`` a block of rows at a time (the float64
    quotient of a whole prototype cube is 1.1 GB).

    Examples
    --------
    >>> _divided(np.ones((3, 2, 2), np.float32), np.array([2.0, 4.0]), rows=2)[2, 1].tolist()
    [0.5, 0.25]
    """
    out = np.empty(cube.shape, np.float32)
    for start in range(0, cube.shape[0], rows):
        out[start : start + rows] = cube[start : start + rows] / response
    return out
