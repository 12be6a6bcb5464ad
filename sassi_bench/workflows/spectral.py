"""The spectral calibration workflow: laser sweeps -> dispersion and blur -> bundle.

:func:`run_spectral_calibration` runs its stages end to end; the notebooks call them
one by one. It drives a rig through the procedure's capture plans, recording everything
in raw sessions, resumable (:mod:`~sassi_bench.workflows.spectral_capture`); decodes
every laser's SLM -> camera correspondences, fits the per-laser field maps, the joint
dispersion model and the blur and grades the result against the procedure's
tolerances (:mod:`~sassi_bench.workflows.spectral_analysis`); and renders its plots and
publishes a calibration bundle (:mod:`~sassi_bench.workflows.spectral_publish`). It
uses device handles only.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from typing import Any

from sassi_bench.rig.rig import Rig
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.spectral_analysis import SpectralCalibration, analyse_spectral_sweeps
from sassi_bench.workflows.spectral_capture import capture_spectral_sweeps
from sassi_bench.workflows.spectral_publish import publish_spectral, render_figures

__all__ = ["run_spectral_calibration"]


@drives_rig("spectral calibration")
def run_spectral_calibration(
    rig: Rig,
    procedure: Mapping[str, Any],
    *,
    session_id: str | None = None,
    data: str | os.PathLike[str] | None = None,
    progress: bool = True,
    publish_bundle: bool = True,
    allow_failed: bool = False,
    figures: bool = True,
) -> SpectralCalibration:
    """Run the spectral calibration end to end: capture, analyse, plot, publish.

    Parameters
    ----------
    rig, procedure, session_id, data, progress
        As for :func:`~sassi_bench.workflows.spectral_capture.capture_spectral_sweeps`.
    publish_bundle, allow_failed
        Publish a bundle; refuse one that failed its checks unless ``allow_failed``.
    figures
        Render the plots (they go into the bundle's ``report/``).

    Returns
    -------
    SpectralCalibration

    Examples
    --------
    >>> result = run_spectral_calibration(open_rig("sim"), proc)  # doctest: +SKIP
    >>> result.bundle_path  # doctest: +SKIP
    PosixPath('calib_data/sim/v0001')
    """
    sweeps = capture_spectral_sweeps(
        rig, procedure, session_id=session_id, data=data, progress=progress
    )
    result = analyse_spectral_sweeps(sweeps, procedure, rig.description)
    if figures:
        render_figures(result)
    if publish_bundle:
        result.bundle_path = publish_spectral(result, data=data, allow_failed=allow_failed)
    return result
