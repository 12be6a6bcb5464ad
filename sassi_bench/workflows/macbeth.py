"""The Macbeth validation on a rig: scan the ColorChecker (and the white diffuser), then
score the scans with :func:`sassi_bench.validate.chart.validate_scans`.

Sessions resume, so re-running with the same session ids re-analyses existing captures (e.g.
with another bundle) without capturing again.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sassi_bench.acquire.exposure import auto_exposure
from sassi_bench.acquire.plan_geometry import planned_macbeth
from sassi_bench.acquire.trigger_gate import armed
from sassi_bench.bundle import CalibrationBundle
from sassi_bench.errors import ProcedureError, step_error
from sassi_bench.rig.rig import Rig
from sassi_bench.validate.chart import validate_scans
from sassi_bench.validate.macbeth import MacbethResult
from sassi_bench.workflows.rig_lock import drives_rig
from sassi_bench.workflows.scan import run_scan

__all__ = ["guide_picture", "run_macbeth"]


def guide_picture(rig: Rig, bundle: CalibrationBundle, light: str) -> NDArray[np.float32]:
    """The guide camera's view of the current scene, warped onto the SLM grid (sRGB-like 0-1).

    Needs a bundle with a guide -> SLM homography.

    Parameters
    ----------
    rig
        Device handles; the scene stays as it is.
    bundle
        A bundle with a guide -> SLM homography.
    light
        The light to show the scene under (auto-exposed for the guide camera).

    Returns
    -------
    ndarray
        (H_slm, W_slm, 3) float32 picture in 0-1.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        picture = guide_picture(open_rig("sim"), load(rig="sim"), "led")
    """
    if bundle.guide_to_slm is None:
        raise ProcedureError(
            step_error(
                "Macbeth patch localisation",
                f"bundle {bundle.rig_name}/{bundle.version} has no guide -> SLM homography",
                "set localisation.image to 'cube' or calibrate the guide homography first",
            )
        )
    exposure = auto_exposure(rig, light, {"kind": "full"}, camera="guide", target_fraction=0.7)
    rig.light.select(light)
    rig.guide_camera.set_exposure(exposure)
    with armed(rig):  # a guide camera on a line trigger exposes for the pulses it passes
        raw = rig.guide_camera.capture().as_float()
    linear = np.clip(raw - np.percentile(raw, 0.5), 0, None)
    linear /= max(float(np.percentile(linear, 99.5)), 1e-12)
    warped = bundle.warp_guide_to_slm(np.clip(linear, 0, 1).astype(np.float32))
    return (np.clip(warped, 0, 1) ** (1 / 2.2)).astype(np.float32)


@drives_rig("validate macbeth")
def run_macbeth(
    rig: Rig,
    bundle: CalibrationBundle,
    procedure: Mapping[str, Any],
    *,
    corners: Sequence[Sequence[float]] | None = None,
    session_id: str | None = None,
    white_session_id: str | None = None,
    roi: Sequence[int] | None = None,
    data=None,
    progress: bool = True,
) -> MacbethResult:
    """Scan the chart (and the diffuser) on ``rig`` and validate ``bundle``.

    Parameters
    ----------
    rig
        Device handles.
    bundle
        The bundle under test: scans are assembled with it.
    procedure
        The ``macbeth_validation`` procedure (scan, white reference, localisation,
        tolerances).
    corners
        SLM ``(u, v)`` centres of patches 1, 6, 24 and 19; skips the chart detection.
    session_id, white_session_id
        Sessions of the chart and diffuser scans; existing ones resume (or are re-analysed).
    roi
        ``(row0, col0, row1, col1)`` of the SLM to scan.
    data
        Data root.
    progress
        Show progress bars.

    Returns
    -------
    MacbethResult
        Per-patch figures, checks and the pictures the report draws.

    Examples
    --------
    Not run here (it drives a bench and stores its frames)::

        from sassi_bench import open_rig
        from sassi_bench.bundle import load
        from sassi_bench.procedure import load_procedure
        result = run_macbeth(open_rig("sim"), load(rig="sim"),
                             load_procedure("macbeth_validation"))
        result.passed, result.summary()["mean_de00"]
        # (True, 0.16)
    """
    procedure = planned_macbeth(procedure, rig.description)
    scan_cfg = procedure["scan"]
    light, pitch = scan_cfg["light"], tuple(scan_cfg["pitch_px"])
    chart = run_scan(
        rig, bundle, scene=scan_cfg["scene"], light=light, pitch=pitch, roi=roi,
        session_id=session_id, data=data, progress=progress, keep_raw=True,
    )  # fmt: skip
    picture = None
    loc = procedure["localisation"]
    if corners is None and loc["method"] == "auto" and loc["image"] == "guide":
        picture = guide_picture(rig, bundle, light)
    white = None
    settings: dict[str, Any] = {
        "chart_session": chart.session.id,
        "light": light,
        "localisation_image": "guide" if picture is not None else "cube",
    }
    if procedure["white_reference"]["source"] == "diffuser":
        diffuser = run_scan(
            rig, bundle, scene=procedure["white_reference"]["diffuser_scene"], light=light,
            pitch=pitch, roi=roi, session_id=white_session_id, data=data, progress=progress,
            keep_raw=True,
        )  # fmt: skip
        white = diffuser.scan
        settings["white_session"] = diffuser.session.id
    return validate_scans(
        chart.scan, bundle, procedure, white=white, corners=corners, picture=picture,
        settings=settings,
    )  # fmt: skip
